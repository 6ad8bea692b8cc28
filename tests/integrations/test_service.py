"""``loadpath serve``: the real server on a free loopback port, driven over HTTP.

The end-to-end test starts ``loadpath serve --port 0`` as its own process with HOME, TMPDIR and the
working directory pointing at empty folders, so "never reads or writes outside its cache folder" is
checked on the file system.  The limit tests run the same server class in a thread with tight limits.
"""

from __future__ import annotations

import json
import os
import subprocess
import threading
import time
import urllib.error
import urllib.request

import pytest
from fixtures import load_script
from integration_helpers import (
    RUNNER,
    VENV_BIN,
    assert_spliced,
    cura_chunks,
    reference,
    write_bad_case,
    write_case,
)
from loadpath import engines
from loadpath.plugin.service import Service, ServiceConfig


def post(
    url: str, payload: object, headers: dict | None = None, raw: bytes | None = None, timeout: float = 300
) -> tuple[int, dict]:
    data = raw if raw is not None else json.dumps(payload).encode()
    req = urllib.request.Request(
        url, data=data, method="POST", headers={"Content-Type": "application/json", **(headers or {})}
    )
    try:
        with urllib.request.urlopen(req, timeout=timeout) as resp:
            return resp.status, json.loads(resp.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def get(url: str) -> tuple[int, dict]:
    try:
        with urllib.request.urlopen(url, timeout=30) as resp:
            return resp.status, json.loads(resp.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """``loadpath serve --port 0`` in its own process, confined: (url, cache, home, tmp, cwd)."""
    root = tmp_path_factory.mktemp("serve")
    dirs = {k: root / k for k in ("cache", "home", "tmp", "cwd")}
    for d in dirs.values():
        d.mkdir()
    env = {
        **os.environ,
        "HOME": str(dirs["home"]),
        "TMPDIR": str(dirs["tmp"]),
        "XDG_CACHE_HOME": str(dirs["home"]),
    }
    proc = subprocess.Popen(
        [
            str(VENV_BIN / "loadpath"),
            "serve",
            "--port",
            "0",
            "--cache",
            str(dirs["cache"]),
            "--timeout",
            "300",
        ],
        cwd=dirs["cwd"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    assert "listening on http://127.0.0.1:" in line, line + proc.stderr.read()
    url = line.split("listening on ", 1)[1].split()[0]
    yield url, dirs
    proc.terminate()
    proc.wait(30)


@pytest.mark.slow
def test_service_processes_and_caches_the_fea(server, sliced, tmp_path):
    url, dirs = server
    assert get(url + "/v1/health") == (
        200,
        {
            "ok": True,
            "version": get(url + "/v1/health")[1]["version"],
            "running": 0,
            "waiting": 0,
            "fea_cache_entries": 0,
        },
    )
    case = write_case(tmp_path)
    first = sliced("prusa", "ohs", "mixed")
    status, ans = post(
        url + "/v1/run",
        {
            "gcode": first.read_text(),
            "loadcase": case.read_text(),
            "settings": {"engine": "streamlines"},
            "report": True,
        },
    )
    assert status == 200 and ans["ok"] and ans["changed"], ans.get("error")
    assert ans["fea_solved"] == 1 and ans["fea_cached"] is False
    assert 0.9 <= ans["summary"]["beta"] <= 1.0 and 0.9 <= ans["summary"]["coverage"] <= 1.0
    assert ans["metrics"]["layers"] and ans["settings"]["engine"] == "streamlines"
    v = ans["verdict"]  # the run's verdict: a field, and the line every front end shows
    assert v["changed"] and v["engine"] == "streamlines" and v["model"].startswith("first-ply failure")
    assert v["failure_load"] is not None and v["failure_load_same_mass"] is not None
    assert v["line"].startswith("loadpath ") and ans["gcode"].splitlines()[1] == "; loadpath: " + v["line"]
    assert_spliced(first, ans["gcode"].encode(), reference(first, case, tmp_path / "ref.gcode"))

    # the same part re-sliced with other print settings (100 % infill): the FEA is not solved again
    again = sliced("prusa", "ohs", "solid")
    status, ans2 = post(
        url + "/v1/run",
        {"gcode": again.read_text(), "loadcase": case.read_text(), "settings": {"engine": "streamlines"}},
    )
    assert status == 200 and ans2["changed"]
    assert ans2["fea_cached"] is True and ans2["fea_solved"] == 0
    assert ans2["times"]["fea"] < ans["times"]["fea"]
    # another load case on the same part: solved
    stronger = case.read_text().replace("1000.0", "2000.0")
    status, ans3 = post(
        url + "/v1/run",
        {"gcode": again.read_text(), "loadcase": stronger, "settings": {"engine": "streamlines"}},
    )
    assert status == 200 and ans3["fea_solved"] == 1
    assert get(url + "/v1/health")[1]["fea_cache_entries"] == 2

    # the Cura plugin's runner through the service: Cura's chunks back, processed
    runner = load_script(RUNNER, "runner_for_service")
    chunks = cura_chunks(sliced("cura", "ohs", "mixed").read_text())
    out = runner.process_chunks(
        chunks,
        str(case),
        {"engine": "streamlines"},
        service_url=url,
        timeout=300,
        report_root=str(tmp_path / "cura-reports"),
    )
    assert out.ok, out.message
    assert len(out.chunks) == len(chunks) and out.chunks != chunks
    assert (tmp_path / "cura-reports" / "last-report" / "metrics.json").is_file()

    # nothing outside the cache folder; nothing left of the jobs inside it
    for name in ("home", "tmp", "cwd"):
        assert list(dirs[name].iterdir()) == [], name
    assert list((dirs["cache"] / "jobs").iterdir()) == []
    assert sorted(p.name for p in dirs["cache"].iterdir()) == ["fea", "home", "jobs", "tmp"]


@pytest.fixture()
def tight(tmp_path):
    """The server class in a thread: one worker, no queue, a 2 MB body limit, a 1 s deadline."""
    svc = Service(
        ServiceConfig(port=0, cache_dir=tmp_path / "cache", max_request_mb=2, workers=1, queue=0, timeout=1.0)
    ).start()
    yield svc
    svc.shutdown()


def test_requests_are_checked_with_clear_json_errors(tight, tmp_path):
    url = tight.url
    ok_case = write_case(tmp_path).read_text()
    cases = [
        (post(url + "/v1/nothing", {}), 404, "not_found"),
        (post(url + "/v1/run", None, raw=b"{not json"), 400, "bad_request"),
        (post(url + "/v1/run", {"gcode": "G1 X1\n"}), 400, "bad_request"),
        (
            post(url + "/v1/run", {"gcode": "G1\n", "gcode_base64": "", "loadcase": ok_case}),
            400,
            "bad_request",
        ),
        (
            post(url + "/v1/run", {"gcode": "G1\n", "loadcase": ok_case, "settings": {"warp": 9}}),
            400,
            "bad_request",
        ),
        (
            post(url + "/v1/run", {"gcode": "G1\n", "loadcase": ok_case, "path": "/etc/passwd"}),
            400,
            "bad_request",
        ),
        (post(url + "/v1/run", {"gcode": "x" * 2_100_000, "loadcase": ok_case}), 413, "too_large"),
        (post(url + "/v1/run", {}, headers={"Content-Type": "text/plain"}), 415, "unsupported_media_type"),
        (post(url + "/v1/run", {}, headers={"Host": "evil.example:80"}), 403, "forbidden"),
        (post(url + "/v1/run", {}, headers={"Origin": "https://evil.example"}), 403, "forbidden"),
        (get(url + "/v1/nothing"), 404, "not_found"),
    ]
    for (status, body), want_status, code in cases:
        assert (status, body["ok"], body["error"]["code"]) == (want_status, False, code), body
        assert body["error"]["message"] and "\n" not in body["error"]["message"]
    status, body = get(url + "/v1/schema")
    assert status == 200 and body["settings"]["engine"]["choices"] == list(engines.NAMES) == ["swarm", "streamlines", "levelset"]


def test_an_upload_over_the_limit_gets_its_answer_not_a_broken_pipe(tight, tmp_path):
    """The server reads away a refused body: a client still sending it used to get EPIPE/ECONNRESET."""
    ok_case = write_case(tmp_path).read_text()
    for size in (2_100_000, 12_000_000, 3_900_000):  # well past the socket buffers; within 2x + 16 MB
        status, body = post(tight.url + "/v1/run", {"gcode": "x" * size, "loadcase": ok_case})
        assert (status, body["error"]["code"]) == (413, "too_large")
        assert "2 MB allowed" in body["error"]["message"]
    # refused for another reason before the body was read: the answer still arrives
    status, body = post(
        tight.url + "/v1/run", {"gcode": "x" * 1_500_000}, headers={"Origin": "https://evil.example"}
    )
    assert (status, body["error"]["code"]) == (403, "forbidden")


def test_loadpath_errors_are_422_with_loadpaths_message(tmp_path, prusa_ohs):
    svc = Service(ServiceConfig(port=0, cache_dir=tmp_path / "cache", timeout=120)).start()
    try:
        status, body = post(
            svc.url + "/v1/run",
            {"gcode": prusa_ohs.read_text(), "loadcase": write_bad_case(tmp_path).read_text()},
        )
    finally:
        svc.shutdown()
    assert status == 422 and body["error"]["code"] == "loadpath_error"
    assert "[[loads]]" in body["error"]["message"]


def test_busy_and_timeout(tight, prusa_ohs, tmp_path):
    """One worker, no queue: a second request meanwhile is refused at once; the first hits its 1 s
    deadline (a real run takes longer), its process is killed and the answer is 504."""
    payload = {"gcode": prusa_ohs.read_text(), "loadcase": write_case(tmp_path).read_text()}
    first: dict = {}
    t = threading.Thread(
        target=lambda: first.update(
            zip(("status", "body"), post(tight.url + "/v1/run", payload), strict=True)
        )
    )
    t.start()
    deadline = time.monotonic() + 5
    while tight.admitted == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    status, body = post(tight.url + "/v1/run", payload)
    assert (status, body["error"]["code"]) == (503, "busy")
    t.join(60)
    assert first["status"] == 504 and first["body"]["error"]["code"] == "timeout", first
    assert tight.running == 0 and tight.admitted == 0
    assert list((tight.cache_dir / "jobs").iterdir()) == []


# ------------------------------------------------------------------------------ forced failures

FAULTHOOK = RUNNER.parents[2] / "tests" / "integrations" / "faulthook"  # fails a stage in the job's process


@pytest.fixture(scope="module")
def faulty(tmp_path_factory, prusa_ohs):
    """``loadpath serve`` whose job processes fail the stage named in a file (``faulthook``), and the
    answer of a run with no fault (the reference; it fills the cache the other stages read)."""
    root = tmp_path_factory.mktemp("serve-faults")
    fault = root / "fault"
    fault.write_text("", encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(FAULTHOOK), "LOADPATH_TEST_FAULT": str(fault)}
    proc = subprocess.Popen(
        [str(VENV_BIN / "loadpath"), "serve", "--port", "0", "--cache", str(root / "cache"), "--timeout", "300"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        line = proc.stdout.readline()
        assert "listening on http://127.0.0.1:" in line, line + proc.stderr.read()
        url = line.split("listening on ", 1)[1].split()[0]
        payload = {
            "gcode": prusa_ohs.read_text(encoding="utf-8"),
            "loadcase": write_case(root).read_text(encoding="utf-8"),
            "settings": {"engine": "streamlines"},
            "report": True,
        }
        status, ref = post(url + "/v1/run", payload)
        assert status == 200 and ref["changed"] and ref["metrics"]["layers"], ref
        yield url, fault, payload, ref, root / "cache"
    finally:
        proc.terminate()
        proc.wait(30)


@pytest.mark.parametrize("stage", ["splice", "check", "rename", "metrics", "report_files", "keep"])
def test_a_forced_failure_at_each_stage_is_what_the_answer_says(faulty, stage):
    """One stage of the real job fails in the service's job process.  Before the write: an error
    answer, no G-code, and the message says none is returned (a bug is the service's 500, a full
    disk names the service's cache folder).  The report's metrics or files: the answer's G-code is
    the processed one, byte for byte the reference's but for the verdict's minute, and the warning
    says what the report lacks.  Never a path inside the job's own (removed) folder."""
    import hashlib

    from fixtures import without_verdict

    url, fault, payload, ref, cache = faulty
    sent = hashlib.sha256(payload["gcode"].encode()).hexdigest()
    payload = {**payload, "report": stage in ("metrics", "report_files")}  # the report costs seconds
    if stage == "keep":  # the splice fails with on_failure = keep: the request's G-code comes back
        payload = {**payload, "settings": {**payload["settings"], "on_failure": "keep"}}
    fault.write_text("splice" if stage == "keep" else stage, encoding="utf-8")
    try:
        status, ans = post(url + "/v1/run", payload)
    finally:
        fault.write_text("", encoding="utf-8")
    assert hashlib.sha256(payload["gcode"].encode()).hexdigest() == sent
    assert "/jobs/" not in json.dumps({k: v for k, v in ans.items() if k != "gcode"}), ans
    assert list((cache / "jobs").iterdir()) == []
    if stage in ("splice", "check", "rename"):
        assert ans["ok"] is False and "gcode" not in ans and "gcode_base64" not in ans
        message = ans["error"]["message"]
        assert message.endswith("; no G-code is returned") and "untouched" not in message, message
        if stage == "rename":
            assert (status, ans["error"]["code"]) == (422, "loadpath_error")
            assert message.startswith(f"cannot write the job's working copy in {str(cache)!r}: No space left on device")
        else:
            assert (status, ans["error"]["code"]) == (500, "internal")
            assert message.startswith("internal error (ValueError: forced failure); please report this")
        return
    if stage == "keep":
        assert status == 200 and ans["ok"] and ans["changed"] is False
        assert hashlib.sha256(ans["gcode"].encode()).hexdigest() == sent  # the request's, byte for byte
        assert ans["error_kept"].startswith("internal error (ValueError: forced failure)")
        assert ans["warnings"] == [f"kept the slicer's G-code: {ans['error_kept']}; the G-code in this answer is "
                                   "the request's, unchanged"], ans["warnings"]
        assert ans["metrics"] is None and ans["verdict"]["line"].count("nothing replaced (failed: internal error") == 1
        return
    assert status == 200 and ans["ok"] and ans["changed"]
    gcode = ans["gcode"].encode()
    assert without_verdict(gcode) == without_verdict(ref["gcode"].encode()) != without_verdict(payload["gcode"].encode())
    # the header was final before a report-files warning, which the answer's verdict counts
    line = ans["verdict"]["line"]
    written = line.replace("; 1 warning", "; 0 warnings") if stage == "report_files" else line
    assert stage != "report_files" or line.endswith("; 1 warning"), line
    assert ans["gcode"].splitlines()[1] == "; loadpath: " + written
    if stage == "metrics":  # the report is made without its metrics, and says so
        assert any("have no figures or metrics (ValueError: forced failure)" in w for w in ans["warnings"])
        assert ans["metrics"] is not None and ans["summary"] == {"beta": None, "coverage": None}
    else:
        assert ans["warnings"] == ["the report could not be written (No space left on device); the G-code "
                                   "in this answer is processed all the same; 'metrics' is null"], ans["warnings"]
        assert ans["metrics"] is None and ans["summary"] == {"beta": None, "coverage": None}


def test_curas_runner_through_the_service_says_when_nothing_was_replaced(faulty, tmp_path):
    """The Cura plugin's runner posts to the service, whose splice fails with ``on_failure = keep``:
    the chunks come back as they were, unmarked, the message says nothing was replaced, and no report
    (not even an earlier one) is left as the last run's."""
    url, fault, payload, _ref, _cache = faulty
    runner = load_script(RUNNER, "runner_for_faults")
    case = tmp_path / "case.toml"
    case.write_text(payload["loadcase"], encoding="utf-8")
    earlier = tmp_path / "reports" / "last-report"
    earlier.mkdir(parents=True)
    (earlier / "metrics.json").write_text('{"source": "earlier.gcode", "changed": true}', encoding="utf-8")
    chunks = [payload["gcode"]]
    fault.write_text("splice", encoding="utf-8")
    try:
        out = runner.process_chunks(chunks, str(case), {"engine": "streamlines", "on_failure": "keep"},
                                    service_url=url, timeout=300, report_root=str(tmp_path / "reports"))
    finally:
        fault.write_text("", encoding="utf-8")
    assert out.ok and not out.changed and out.chunks == chunks
    text = runner.user_message(out).splitlines()
    assert text[0] == "Loadpath replaced nothing; the G-code is saved as Cura sliced it."
    assert "nothing replaced (failed: internal error (ValueError: forced failure)" in text[1]
    assert text[2].startswith("warning: kept the slicer's G-code: internal error")
    assert not earlier.exists()
    assert runner.report_summary(str(earlier)).startswith("No report of the last run")
