"""``loadpath serve``: a local HTTP service for slicer plugins (loopback only, JSON in and out).

Endpoints (the README documents the JSON in full)::

    GET  /v1/health   {"ok": true, "version": ..., "running": n, "waiting": n, "fea_cache_entries": n}
    GET  /v1/schema   the settings a request may give ({"settings": {name: {type, default, unit, ...}}})
    POST /v1/run      {"gcode" | "gcode_base64", "loadcase", "settings"?, "slicer_settings"?,
                       "slicer_env"?, "name"?, "report"?, "force"?}
                      -> {"ok": true, "gcode" | "gcode_base64", "changed", "warnings", "metrics",
                          "summary", "verdict", "fea_cached", "times", "settings"}

Errors are ``{"ok": false, "error": {"code": ..., "message": ...}}`` with an HTTP status: 400
``bad_request``, 403 ``forbidden`` (a Host or Origin that is not loopback), 404 ``not_found``, 408
``request_timeout`` (the body did not arrive within ``read_timeout``), 411
``length_required``, 413 ``too_large``, 415 ``unsupported_media_type``, 422 ``loadpath_error`` (the
one-line message ``loadpath run`` would print), 503 ``busy``, 504 ``timeout``, 500 ``internal`` (a
bug or lack of memory, in the service or its job).  A failed job's message ends with "no G-code is
returned" and names no file of the job's own folder (:func:`~.service_job.in_service_terms`).

Safety: the socket is bound to 127.0.0.1 only; requests carry text, never paths, and every file the
service writes (each request's working folder, the FEA cache) is inside its cache folder (``TMPDIR``
points there too).  The request body is bounded (``max_request_mb``), at most ``workers`` jobs run at
once and ``queue`` more wait (others get 503 at once), and each request has a deadline: its job runs
in a child process that is killed when the deadline passes (504).

Cache: :mod:`loadpath.cache` (the one ``loadpath run`` uses, here in the service's own folder
``CACHE/fea``) keeps each solved stress analysis per part outline and load case, and each engine
run's paths, so re-slicing with other print settings does not solve again.  Each request runs in a
child process (:mod:`loadpath.plugin.service_job`).
"""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import threading
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from loadpath.plugin.localhttp import HOST, check_host_origin, read_json_body, short
from loadpath.plugin.service_job import RequestError, check_request, child, confine
from loadpath.procs import warm_start_method

__all__ = ["ServiceConfig", "Service", "default_cache_dir", "RequestError", "confine"]

def _start_forkserver_quietly() -> None:
    """Start the forkserver with stderr on /dev/null: its job processes answer through their pipe, and
    one killed while it still reads its request (the service stopping) would print multiprocessing's
    unpickling traceback into the service's log."""
    from multiprocessing import forkserver

    try:
        saved = os.dup(2)
    except OSError:
        return
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.close(devnull)
        forkserver.ensure_running()
    finally:
        os.dup2(saved, 2)
        os.close(saved)


class _Server(ThreadingHTTPServer):
    """The HTTP server; a client that hangs up or breaks the protocol is one log line, not a traceback."""

    daemon_threads = True

    def handle_error(self, request: Any, client_address: Any) -> None:
        import sys

        exc = sys.exc_info()[1]
        what = ("disconnected" if isinstance(exc, (ConnectionError, TimeoutError))
                else "request failed")
        print(f"loadpath serve: client {client_address[0]}:{client_address[1]} {what} "
              f"({type(exc).__name__})", file=sys.stderr, flush=True)


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/loadpath/serve`` (default ``~/.cache/loadpath/serve``)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "loadpath" / "serve"


@dataclass(frozen=True)
class ServiceConfig:
    """Limits and places of the service.

    Attributes
    ----------
    port : int
        TCP port on 127.0.0.1 (0: any free port).
    cache_dir : Path
    max_request_mb : float
        Largest request body, MB.
    workers : int
        Jobs running at once.
    queue : int
        Requests waiting for a worker beyond those; more are refused with 503.
    timeout : float, s
        Per request, from its arrival.
    fea_cache_entries : int
        FEA results kept.
    read_timeout : float, s
        Time a client has to send its whole request body; a request takes its place among the
        running and waiting ones only once its body is read, so slow clients hold no place.
    """

    port: int = 8765
    cache_dir: Path = field(default_factory=default_cache_dir)
    max_request_mb: float = 200.0
    workers: int = 1
    queue: int = 4
    timeout: float = 600.0
    fea_cache_entries: int = 64
    read_timeout: float = 30.0


# ---------------------------------------------------------------------------------------------- server


class Service:
    """The HTTP server and its limits; :meth:`serve_forever` or :meth:`start` (a background thread)."""

    def __init__(self, config: ServiceConfig) -> None:
        self.config = config
        self.cache_dir = Path(config.cache_dir)
        for sub in ("", "fea", "jobs", "tmp", "home"):
            (self.cache_dir / sub).mkdir(parents=True, exist_ok=True, mode=0o700)
        for stale in (self.cache_dir / "jobs").iterdir():  # left by a killed service
            shutil.rmtree(stale, ignore_errors=True)
        self._slots = threading.BoundedSemaphore(config.workers)
        self._lock = threading.Lock()
        self.admitted = 0
        self.running = 0
        self._ctx = multiprocessing.get_context(warm_start_method())
        if self._ctx.get_start_method() == "forkserver":
            self._ctx.set_forkserver_preload(["loadpath.plugin.job", "loadpath.pipeline", "loadpath.fea"])
            _start_forkserver_quietly()
        handler = type("Handler", (_Handler,), {"service": self})
        self._procs: set[Any] = set()
        self._closing = False
        self._works: set[Path] = set()
        self.httpd = _Server((HOST, config.port), handler)
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """``http://127.0.0.1:<port>``."""
        return f"http://{HOST}:{self.httpd.server_address[1]}"

    def serve_forever(self) -> None:
        """Serve until :meth:`shutdown` (or KeyboardInterrupt)."""
        self.httpd.serve_forever()

    def start(self) -> Service:
        """Serve in a background thread; returns self."""
        self._thread = threading.Thread(target=self.serve_forever, name="loadpath-serve", daemon=True)
        self._thread.start()
        return self

    def shutdown(self) -> None:
        """Stop serving and close the socket; end running jobs and remove their folders."""
        self.httpd.shutdown()
        self.httpd.server_close()
        self.close_jobs()

    def close_jobs(self) -> int:
        """Kill every running job's process and remove its folder; how many were running."""
        with self._lock:
            self._closing = True
            procs, works = list(self._procs), list(self._works)
        for proc in procs:
            try:
                proc.kill()
                proc.join(5)
            except (OSError, ValueError, AssertionError):
                pass
        for work in works:
            shutil.rmtree(work, ignore_errors=True)
        return len(works)

    # ------------------------------------------------------------------------------------------ jobs
    def admit(self) -> bool:
        """Take a place among the running and waiting requests (False when full)."""
        with self._lock:
            if self.admitted >= self.config.workers + self.config.queue:
                return False
            self.admitted += 1
            return True

    def release(self) -> None:
        """Give back a place taken by :meth:`admit`."""
        with self._lock:
            self.admitted -= 1

    def run(self, req: dict[str, Any], deadline: float) -> dict[str, Any]:
        """Run a checked /v1/run request in a child process before ``deadline`` (time.monotonic)."""
        if not self._slots.acquire(timeout=max(0.0, deadline - time.monotonic())):
            raise RequestError(
                503, "busy", f"every worker stayed busy for {self.config.timeout:g} s; retry later"
            )
        work = self.cache_dir / "jobs" / uuid.uuid4().hex
        try:
            with self._lock:
                self.running += 1
            work.mkdir(mode=0o700)
            recv, send = self._ctx.Pipe(duplex=False)
            proc = self._ctx.Process(
                target=child,
                args=(
                    send,
                    req,
                    str(work),
                    str(self.cache_dir / "fea"),
                    self.config.fea_cache_entries,
                    str(self.cache_dir / "tmp"),
                ),
            )
            with self._lock:
                self._works.add(work)
            proc.start()
            with self._lock:
                self._procs.add(proc)
                if self._closing:  # the service stopped while this job was starting
                    proc.kill()
            send.close()
            try:
                ready = recv.poll(max(0.0, deadline - time.monotonic()))
                msg = recv.recv() if ready else None
            except EOFError:
                msg = (
                    "error",
                    500,
                    "internal",
                    "the job's process stopped without an answer (out of memory?)",
                )
            finally:
                if msg is None and proc.is_alive():
                    proc.kill()
                proc.join(5)
                recv.close()
            if msg is None:
                raise RequestError(
                    504,
                    "timeout",
                    f"the job did not finish within {self.config.timeout:g} s; "
                    "the G-code is unchanged (use fewer replaced layers or a longer --timeout)",
                )
            if msg[0] != "ok":
                raise RequestError(*msg[1:])
            return msg[1]
        finally:
            shutil.rmtree(work, ignore_errors=True)
            with self._lock:
                self.running -= 1
                self._works.discard(work)
                self._procs = {p for p in self._procs if p.is_alive()}
            self._slots.release()


class _Handler(BaseHTTPRequestHandler):
    service: Service
    server_version = "loadpath-serve"
    timeout = 60  # seconds a client may take to send its request (slow clients do not hold a worker)

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base class's name)
        pass  # quiet: the command prints one line per request itself

    def _send(self, status: int, payload: Mapping[str, Any]) -> None:
        body = json.dumps(payload).encode("utf-8")
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _error(self, exc: RequestError) -> None:
        self._send(exc.status, {"ok": False, "error": {"code": exc.code, "message": exc.message}})

    def _discard_body(self) -> None:
        """Read and drop a body the answer does not need, so the client can read that answer.

        Closing a socket with unread data in it resets the connection: a client still sending
        (a 413 for a large upload) gets a broken pipe instead of the error.  Bodies up to twice
        the limit (at least 16 MB) are read away; a larger one closes the connection unread.
        """
        if self._body_read:
            return
        self._body_read = True
        length = self.headers.get("Content-Length")
        if length is None or not length.isdigit():
            self.close_connection = True
            return
        left = int(length)
        if left > max(2 * self.service.config.max_request_mb * 1e6, 16e6):
            self.close_connection = True
            return
        try:
            while left > 0:
                chunk = self.rfile.read(min(left, 1 << 16))
                if not chunk:
                    break
                left -= len(chunk)
        except (OSError, TimeoutError):
            self.close_connection = True

    def _check_origin(self) -> None:
        """Refuse requests addressed to another host name (DNS rebinding) or sent by a web page.

        :func:`loadpath.plugin.localhttp.check_host_origin` with this service's port: ``Host`` a
        plain loopback name (``evil@localhost:PORT`` refused), any ``Origin`` but this service's own
        refused (slicer plugins send none; a page on another local port is refused).
        """
        check_host_origin(self.headers, self.server.server_address[1])

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        try:
            self._check_origin()
            if self.path == "/v1/health":
                svc = self.service
                self._send(
                    200,
                    {
                        "ok": True,
                        "version": _version(),
                        "running": svc.running,
                        "waiting": max(0, svc.admitted - svc.running),
                        "fea_cache_entries": len(list((svc.cache_dir / "fea" / "fea").glob("*.entry"))),
                    },
                )
            elif self.path == "/v1/schema":
                from loadpath.plugin.settings import SCHEMA, field_json

                self._send(200, {"ok": True, "settings": {f.name: field_json(f) for f in SCHEMA}})
            else:
                raise RequestError(
                    404, "not_found", f"no {self.path}; use GET /v1/health, GET /v1/schema or POST /v1/run"
                )
        except RequestError as exc:
            self._error(exc)

    def do_POST(self) -> None:  # noqa: N802
        t0 = time.monotonic()
        svc = self.service
        self._body_read = False
        try:
            req = self._read_request(svc)  # before a place is taken: a slow client holds none
        except RequestError as exc:
            self._answer(exc.status, {"ok": False, "error": {"code": exc.code, "message": exc.message}})
            return
        except (OSError, TimeoutError):
            self.close_connection = True  # the client went away
            return
        if not svc.admit():
            self._answer(503, {"ok": False, "error": {"code": "busy", "message": (
                f"{svc.config.workers} job(s) running and {svc.config.queue} waiting; retry later")}})
            return
        # the place is given back before the answer is written: a client that sends its next
        # request as soon as it reads this answer must not find its own finished job still running
        try:
            status, payload = 200, {"ok": True, **svc.run(req, t0 + svc.config.timeout)}
        except RequestError as exc:
            status, payload = exc.status, {"ok": False, "error": {"code": exc.code, "message": exc.message}}
        finally:
            svc.release()
        self._answer(status, payload)

    def _answer(self, status: int, payload: Mapping[str, Any]) -> None:
        try:
            self._discard_body()  # a refused request's body (nothing once the body was read)
            self._send(status, payload)
        except OSError:
            self.close_connection = True

    def _read_body(self, length: int, deadline: float) -> bytes:
        """The body, read before ``deadline`` (time.monotonic) whatever pace the client sends at."""
        parts, left = [], length
        sock = self.connection
        while left > 0:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError
            sock.settimeout(remaining)  # a timeout ends the read: the stream is not read further
            chunk = self.rfile.read1(min(left, 1 << 16))
            if not chunk:
                raise ConnectionResetError("the client closed the connection before sending its body")
            parts.append(chunk)
            left -= len(chunk)
        return b"".join(parts)

    def _read_request(self, svc: Service) -> dict[str, Any]:
        """Check the headers, read the body within the read deadline and check it (raises RequestError)."""
        self._check_origin()
        if self.path != "/v1/run":
            raise RequestError(404, "not_found", f"no POST {self.path}; use POST /v1/run")
        deadline = time.monotonic() + svc.config.read_timeout

        def read(n: int) -> bytes:
            self._body_read = True  # from here on the body is the request's, never drained
            return self._read_body(n, deadline)

        try:
            req = read_json_body(self.headers, self.rfile, svc.config.max_request_mb, "loadpath serve --max-mb", read)
        except RequestError as exc:
            if exc.status in (411, 413):
                self.close_connection = True
            raise
        except TimeoutError:
            self.close_connection = True
            raise RequestError(408, "request_timeout", f"the body did not arrive within "
                               f"{svc.config.read_timeout:g} s; send it at once") from None
        try:
            return check_request(req)
        except RecursionError:
            raise RequestError(400, "bad_request", "the body's JSON is nested too deeply") from None


def _version() -> str:
    from loadpath import __version__

    return __version__
