"""The editor's server: loopback only, other hosts and origins refused, nothing served but its page."""

from __future__ import annotations

import http.client
import json
import socket
from importlib import resources

import pytest

pytestmark = pytest.mark.slow


def _request(port, method, path, body=None, headers=None):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    h = {"Host": f"127.0.0.1:{port}", **(headers or {})}
    data = None
    if body is not None:
        data = json.dumps(body).encode()
        h.setdefault("Content-Type", "application/json")
        h["Content-Length"] = str(len(data))
    conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
    for k, v in h.items():
        conn.putheader(k, v)
    conn.endheaders(data)
    r = conn.getresponse()
    out = r.status, dict(r.getheaders()), r.read()
    conn.close()
    return out


@pytest.fixture
def running(editor, test_stls, tmp_path):
    (stl,) = test_stls("bracket")
    return editor(stl, tmp_path / "case.toml")


def test_listens_on_loopback_only(running):
    port = running.port
    listening = []
    with open("/proc/net/tcp") as f:  # Linux: local address as hex ip:port, state 0A = LISTEN
        for line in f.readlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            ip, p = local.split(":")
            if int(p, 16) == port and state == "0A":
                listening.append(ip)
    assert listening == ["0100007F"]  # 127.0.0.1
    others = {a[4][0] for a in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)} - {"127.0.0.1"}
    for ip in others - {a for a in others if a.startswith("127.")}:
        with pytest.raises(OSError):
            socket.create_connection((ip, port), timeout=2).close()


def test_other_hosts_and_origins_are_refused(running):
    port = running.port
    ok, h, page = _request(port, "GET", "/")
    assert ok == 200 and b"<title>loadpath: load-case editor</title>" in page
    assert "default-src 'none'" in h["Content-Security-Policy"] and h["X-Content-Type-Options"] == "nosniff"
    case = {"case": {"version": 1}}
    refused = [
        _request(port, "GET", "/", headers={"Host": f"evil.example:{port}"}),  # DNS rebinding
        _request(port, "GET", "/api/start", headers={"Host": "attacker.test"}),
        _request(port, "POST", "/api/resolve", case, headers={"Origin": "http://evil.example"}),
        _request(
            port, "POST", "/api/save", case, headers={"Origin": "http://127.0.0.1:1"}
        ),  # another local page
        _request(port, "POST", "/api/save", case, headers={"Origin": "null"}),
        _request(port, "POST", "/api/solve", case, headers={"Sec-Fetch-Site": "cross-site"}),
    ]
    for status, _, body in refused:
        assert status == 403 and json.loads(body)["error"]["code"] == "forbidden"
    assert not running.case.exists()  # the refused saves wrote nothing
    status, _, body = _request(
        port,
        "POST",
        "/api/resolve",
        case,
        headers={"Origin": f"http://127.0.0.1:{port}", "Sec-Fetch-Site": "same-origin"},
    )
    assert status == 200 and "missing section [[supports]]" in json.loads(body)["errors"][0]["message"]


def test_serves_nothing_outside_its_own_files(running):
    port = running.port
    static = resources.files("loadpath.plugin.editor") / "static"
    status, h, js = _request(port, "GET", "/editor.js?../../setup.cfg")
    assert status == 200 and js == (static / "editor.js").read_bytes()
    for path in [
        "/../setup.cfg",
        "/%2e%2e/%2e%2e/setup.cfg",
        "/..%2f..%2fsetup.cfg",
        "/static/editor.js",
        "/editor.js/../../session.py",
        "//etc/passwd",
        "/api/../../../../etc/passwd",
        "/session.py",
        "/index.html/..",
        "/editor.css%00.py",
        f"/{running.case.name}",
        str(running.part),
    ]:
        status, _, body = _request(port, "GET", path)
        assert status == 404, path
        assert json.loads(body)["error"]["code"] == "not_found"
        assert b"[metadata]" not in body and b"root:" not in body


def test_bodies_are_bounded_and_checked(running):
    port = running.port
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    conn.putrequest("POST", "/api/resolve")
    conn.putheader("Content-Type", "application/json")
    conn.putheader("Content-Length", str(6_000_000))
    conn.endheaders()
    r = conn.getresponse()
    assert r.status == 413 and json.loads(r.read())["error"]["code"] == "too_large"
    conn.close()
    status, _, body = _request(
        port, "POST", "/api/resolve", None, headers={"Content-Type": "text/plain", "Content-Length": "2"}
    )
    assert status == 415
    status, _, body = _request(port, "POST", "/api/solve", {"case": {}, "layer": "0"})
    assert status == 400 and "layer must be an integer" in json.loads(body)["error"]["message"]


def test_bad_input_is_one_line_naming_the_fix(test_stls, tmp_path):
    import subprocess

    from editor_fixtures import LOADPATH

    (stl,) = test_stls("bracket")
    bad_case = tmp_path / "bad.toml"
    bad_case.write_text(
        'version = 1\n[[supports]]\nwhere = { side = "x_min" }\nfix = ["x"]\n', encoding="utf-8"
    )
    open_mesh = tmp_path / "open.stl"
    open_mesh.write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 1\nvertex 0 1 1\nendloop\n"
        "endfacet\nendsolid t\n",
        encoding="utf-8",
    )
    cases = [
        ([str(tmp_path / "missing.gcode")], "does not exist or is not a file; give a G-code or STL file"),
        (
            [str(stl), "--loadcase", str(bad_case)],
            "bad.toml: missing section [[loads]]; add at least one load",
        ),
        ([str(open_mesh)], "is not closed; repair the mesh (it must be watertight)"),
        ([str(stl), "--port", "70000"], "--port 70000 must lie within 0..65535"),
    ]
    for args, words in cases:
        r = subprocess.run(
            [str(LOADPATH), "edit", *args, "--no-browser"], capture_output=True, text=True, timeout=120
        )
        assert r.returncode == 1, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("loadpath: ") and words in lines[0], r.stderr
    assert not (tmp_path / "missing.toml").exists()
