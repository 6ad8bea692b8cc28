"""The editor's HTTP server: the page's own files and a small JSON API, on 127.0.0.1 only.

Routes::

    GET  /  /editor.js  /editor.css    the page (package data of loadpath.plugin.editor, read once)
    GET  /api/start                    the part, the case to show, materials and [toolpath] help
    POST /api/resolve  {"case"}        what each selector picks, errors, the TOML Save would write
    POST /api/solve    {"case", "layer"}   starts the solve (stress, path preview, stiffness)
    POST /api/solve-result  {"job"}    its answer, or "running" and the seconds so far
    POST /api/save     {"case"}        writes the TOML to the one file named on the command line

Protections are :mod:`loadpath.plugin.localhttp`'s (the ones ``loadpath serve`` uses), with the
Origin held to this server's own port; request bodies are capped at :data:`MAX_BODY_MB`; nothing
is served but the three files above (no path from a request ever reaches the file system), and the
only file written is the save path.  Pages carry a Content-Security-Policy that allows no request
outside the server.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Mapping
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any
from urllib.parse import urlsplit

from loadpath.plugin.editor.session import EditorSession
from loadpath.plugin.localhttp import HOST, RequestError, check_host_origin, read_json_body

__all__ = ["EditorServer", "MAX_BODY_MB", "STATIC"]

MAX_BODY_MB = 5.0
"""Largest request body (a load case as JSON is a few kB)."""

STATIC = {
    "/": ("index.html", "text/html; charset=utf-8"),
    "/editor.js": ("editor.js", "text/javascript; charset=utf-8"),
    "/editor.css": ("editor.css", "text/css; charset=utf-8"),
}
"""The only paths served as files, and the package files they are."""

_CSP = (
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "connect-src 'self'; form-action 'none'; frame-ancestors 'none'; base-uri 'none'"
)


def _static_files() -> dict[str, tuple[bytes, str]]:
    pkg = resources.files("loadpath.plugin.editor") / "static"
    return {route: ((pkg / name).read_bytes(), ctype) for route, (name, ctype) in STATIC.items()}


class EditorServer:
    """Serve one :class:`EditorSession` on ``127.0.0.1:port`` (0: any free port)."""

    def __init__(self, session: EditorSession, port: int = 0) -> None:
        self.session = session
        self.files = _static_files()
        handler = type("Handler", (_Handler,), {"editor": self})
        self.httpd = ThreadingHTTPServer((HOST, port), handler)
        self.httpd.daemon_threads = True
        self.port = int(self.httpd.server_address[1])
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """``http://127.0.0.1:<port>/``."""
        return f"http://{HOST}:{self.port}/"

    def start(self) -> EditorServer:
        """Serve in a background thread; returns self."""
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="loadpath-edit", daemon=True)
        self._thread.start()
        return self

    def serve_forever(self) -> None:
        """Serve until interrupted."""
        self.httpd.serve_forever()

    def shutdown(self) -> None:
        """Stop serving, close the socket and remove the work folder."""
        if self._thread is not None:
            self.httpd.shutdown()
        self.httpd.server_close()
        self.session.close()


class _Handler(BaseHTTPRequestHandler):
    editor: EditorServer
    server_version = "loadpath-edit"
    timeout = 60

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base class's name)
        pass

    def _headers(self, status: int, ctype: str, length: int) -> None:
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(length))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Referrer-Policy", "no-referrer")
        self.send_header("Content-Security-Policy", _CSP)
        self.end_headers()

    def _json(self, status: int, payload: Mapping[str, Any]) -> None:
        body = json.dumps(payload).encode("utf-8")
        self._headers(status, "application/json", len(body))
        self.wfile.write(body)

    def _error(self, exc: RequestError) -> None:
        self.close_connection = True
        self._json(exc.status, {"ok": False, "error": {"code": exc.code, "message": exc.message}})

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        try:
            check_host_origin(self.headers, port=self.editor.port)
            path = urlsplit(self.path).path
            if path in self.editor.files:
                data, ctype = self.editor.files[path]
                self._headers(200, ctype, len(data))
                self.wfile.write(data)
            elif path == "/api/start":
                self._json(200, self.editor.session.start())
            else:
                raise RequestError(404, "not_found", f"no {path}; the editor serves only its own page")
        except RequestError as exc:
            self._error(exc)

    def do_POST(self) -> None:  # noqa: N802
        try:
            check_host_origin(self.headers, port=self.editor.port)
            path = urlsplit(self.path).path
            if path not in ("/api/resolve", "/api/solve", "/api/solve-result", "/api/save"):
                raise RequestError(404, "not_found", f"no POST {path}")
            req = read_json_body(self.headers, self.rfile, MAX_BODY_MB, "a load case is a few kB")
            if not isinstance(req, dict):
                raise RequestError(400, "bad_request", 'send {"case": {...}}')
            s = self.editor.session
            case = req.get("case")
            if path == "/api/resolve":
                answer = s.resolve(case)
            elif path == "/api/save":
                answer = s.save(case)
            elif path == "/api/solve-result":
                answer = s.solve_result(req.get("job"))
            else:
                layer = req.get("layer", 0)
                if not isinstance(layer, int) or isinstance(layer, bool):
                    raise RequestError(400, "bad_request", "layer must be an integer")
                answer = s.solve_start(case, layer)
            self._json(200, answer)
        except RequestError as exc:
            self._error(exc)
        except Exception as exc:  # a bug: one line to the page, the server keeps running
            self._json(
                500,
                {
                    "ok": False,
                    "error": {
                        "code": "internal",
                        "message": (
                            f"internal error ({type(exc).__name__}: {' '.join(str(exc).split())}); "
                            "please report it with the part and the load case"
                        ),
                    },
                },
            )
