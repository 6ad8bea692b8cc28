"""``loadpath serve``: a local HTTP service for slicer plugins (loopback only, JSON in and out).

Endpoints (the README documents the JSON in full)::

    GET  /v1/health   {"ok": true, "version": ..., "running": n, "waiting": n, "fea_cache_entries": n}
    GET  /v1/schema   the settings a request may give ({"settings": {name: {type, default, unit, ...}}})
    POST /v1/run      {"gcode" | "gcode_base64", "loadcase", "settings"?, "slicer_settings"?,
                       "slicer_env"?, "name"?, "report"?}
                      -> {"ok": true, "gcode" | "gcode_base64", "changed", "warnings", "metrics",
                          "summary", "fea_cached", "times", "settings"}

Errors are ``{"ok": false, "error": {"code": ..., "message": ...}}`` with an HTTP status: 400
``bad_request``, 403 ``forbidden`` (a Host or Origin that is not loopback), 404 ``not_found``, 411
``length_required``, 413 ``too_large``, 415 ``unsupported_media_type``, 422 ``loadpath_error`` (the
one-line message ``loadpath run`` would print), 503 ``busy``, 504 ``timeout``, 500 ``internal``.

Safety: the socket is bound to 127.0.0.1 only; requests carry text, never paths, and every file the
service writes (each request's working folder, the FEA cache) is inside its cache folder (``TMPDIR``
points there too).  The request body is bounded (``max_request_mb``), at most ``workers`` jobs run at
once and ``queue`` more wait (others get 503 at once), and each request has a deadline: its job runs
in a child process that is killed when the deadline passes (504).

FEA cache: solving the stress analysis is the expensive part that does not depend on the print
settings; :class:`FEACache` keeps each solved :class:`~loadpath.fea.Analysis` under a hash of the
part outlines (per slab, at 1 µm), the load case's supports, loads, material, frame and object, and
the loadpath version.  Re-slicing with other print settings (infill, speeds, temperatures) reuses it;
a changed outline or load case solves again.  At most ``fea_cache_entries`` results are kept (least
recently used dropped).
"""

from __future__ import annotations

import base64
import dataclasses
import hashlib
import json
import multiprocessing
import os
import pickle
import shutil
import threading
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

__all__ = ["ServiceConfig", "Service", "FEACache", "fea_key", "default_cache_dir", "handle_run", "confine"]

HOST = "127.0.0.1"
_LOOPBACK = {"127.0.0.1", "localhost", "::1"}


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/loadpath/serve`` (default ``~/.cache/loadpath/serve``)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "loadpath" / "serve"


def confine(cache_dir: Path) -> None:
    """Point this process's temporary folder and home into ``cache_dir``.

    Libraries keep settings under the home folder (FLTK, under gmsh, creates ``~/.fltk``): with both
    inside the cache folder, nothing is written outside it.
    """
    import tempfile

    cache_dir = Path(cache_dir)
    for sub in ("tmp", "home"):
        (cache_dir / sub).mkdir(parents=True, exist_ok=True, mode=0o700)
    home = str(cache_dir / "home")
    os.environ.update(
        {
            "TMPDIR": str(cache_dir / "tmp"),
            "HOME": home,
            "XDG_CONFIG_HOME": home + "/.config",
            "XDG_CACHE_HOME": home + "/.cache",
            "XDG_DATA_HOME": home + "/.local/share",
        }
    )
    tempfile.tempdir = str(cache_dir / "tmp")


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
    """

    port: int = 8765
    cache_dir: Path = field(default_factory=default_cache_dir)
    max_request_mb: float = 200.0
    workers: int = 1
    queue: int = 4
    timeout: float = 600.0
    fea_cache_entries: int = 64


class RequestError(Exception):
    """A request that gets an error answer: HTTP status, code, one-line message."""

    def __init__(self, status: int, code: str, message: str) -> None:
        super().__init__(message)
        self.status, self.code, self.message = status, code, message


# ---------------------------------------------------------------------------------------------- FEA cache


def fea_key(rb: Any) -> str:
    """Hash of what a stress analysis depends on: outlines, load case (without [toolpath]), version."""
    import shapely
    from loadpath import __version__

    h = hashlib.sha256(f"loadpath {__version__}\n{rb.analysis}\n".encode())
    for slab in rb.body.slabs:
        h.update(f"{slab.z0:.4f} {slab.z1:.4f}\n".encode())
        outline = shapely.normalize(shapely.set_precision(slab.outline, 1e-3))
        h.update(shapely.to_wkb(outline, hex=False))
    lc = rb.loadcase
    h.update(repr((lc.version, lc.supports, lc.loads, lc.material, lc.frame, lc.object)).encode())
    return h.hexdigest()[:32]


class FEACache:
    """``analyze(rb, pitch=...)`` that reuses solved analyses kept in ``folder`` (pickles).

    Only this service writes the folder (mode 0700 under the user's cache), so its pickles are
    trusted.  ``hits`` and ``misses`` count this instance's lookups.
    """

    def __init__(self, folder: Path, max_entries: int = 64) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        self.max_entries = max_entries
        self.hits = 0
        self.misses = 0

    def __call__(self, rb: Any, pitch: float | None = None, **kw: Any) -> Any:
        """Return the cached analysis of ``rb`` (attached to ``rb``), else solve and keep it."""
        from loadpath import fea

        path = self.folder / f"{fea_key(rb)}.pickle"
        if path.is_file():
            try:
                with path.open("rb") as fh:
                    cached = pickle.load(fh)
                os.utime(path)
                self.hits += 1
                return dataclasses.replace(cached, resolved=rb, _cache={})
            except (OSError, pickle.UnpicklingError, EOFError, AttributeError, TypeError):
                path.unlink(missing_ok=True)  # damaged or from another version: solve again
        analysis = fea.analyze(rb, pitch=pitch, **kw)
        self.misses += 1
        tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
        with tmp.open("wb") as fh:
            pickle.dump(dataclasses.replace(analysis, _cache={}), fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
        self.prune()
        return analysis

    def entries(self) -> list[Path]:
        """List the cached results, least recently used first."""
        stamped = []
        for p in self.folder.glob("*.pickle"):
            try:
                stamped.append((p.stat().st_mtime, p))
            except FileNotFoundError:  # pruned by another job meanwhile
                continue
        return [p for _, p in sorted(stamped)]

    def prune(self) -> None:
        """Drop the least recently used results beyond ``max_entries``."""
        entries = self.entries()
        for p in entries[: max(0, len(entries) - self.max_entries)]:
            p.unlink(missing_ok=True)


# ---------------------------------------------------------------------------------------------- one job


def _check_request(req: Any) -> dict[str, Any]:
    """Validate a /v1/run body's shape (values are checked by loadpath itself)."""
    from loadpath.plugin.settings import SCHEMA

    if not isinstance(req, dict):
        raise RequestError(400, "bad_request", "the body must be a JSON object")
    if ("gcode" in req) == ("gcode_base64" in req):
        raise RequestError(
            400, "bad_request", "give the G-code as exactly one of 'gcode' (text) or 'gcode_base64'"
        )
    if not isinstance(req.get("gcode", req.get("gcode_base64")), str):
        raise RequestError(400, "bad_request", "'gcode' / 'gcode_base64' must be a string")
    if not isinstance(req.get("loadcase"), str) or not req["loadcase"].strip():
        raise RequestError(400, "bad_request", "'loadcase' must be the load case's TOML text")
    for key in ("settings", "slicer_settings", "slicer_env"):
        if not isinstance(req.get(key, {}), dict):
            raise RequestError(400, "bad_request", f"'{key}' must be a JSON object")
    names = {f.name for f in SCHEMA}
    unknown = sorted(set(req.get("settings", {})) - names)
    if unknown:
        raise RequestError(
            400, "bad_request", f"unknown setting(s) {', '.join(unknown)}; GET /v1/schema lists them"
        )
    extra = sorted(
        set(req)
        - {"gcode", "gcode_base64", "loadcase", "settings", "slicer_settings", "slicer_env", "name", "report"}
    )
    if extra:
        raise RequestError(400, "bad_request", f"unknown field(s) {', '.join(extra)}")
    return req


def handle_run(req: Mapping[str, Any], work: Path, fea_dir: Path, fea_entries: int) -> dict[str, Any]:
    """Run one request in folder ``work`` (created, not removed); the answer's JSON (without ``ok``).

    Raises
    ------
    LoadpathError
        The job failed (its one-line message goes to the client).
    """
    from loadpath.errors import SettingsError
    from loadpath.plugin.batch import metrics_summary
    from loadpath.plugin.job import JobRequest, run_job

    binary = "gcode_base64" in req
    name = Path(str(req.get("name") or ("part.bgcode" if binary else "part.gcode"))).name
    inp = work / name
    if binary:
        try:
            inp.write_bytes(base64.b64decode(req["gcode_base64"], validate=True))
        except ValueError:
            raise SettingsError("'gcode_base64' is not valid base64; encode the file's bytes") from None
    else:
        inp.write_bytes(req["gcode"].encode("utf-8"))
    case = work / "loadcase.toml"
    case.write_text(req["loadcase"], encoding="utf-8")
    slicer = None
    if req.get("slicer_settings"):
        slicer = work / "slicer_settings.json"
        slicer.write_text(json.dumps(req["slicer_settings"]), encoding="utf-8")
    out = work / f"out{inp.suffix or '.gcode'}"
    report = work / "report" if req.get("report") else None
    cache = FEACache(fea_dir, fea_entries)
    env = {str(k): str(v) for k, v in (req.get("slicer_env") or {}).items()}
    result = run_job(
        JobRequest(
            input=inp,
            loadcase=case,
            output=out,
            report=report,
            cli={**req.get("settings", {}), "jobs": 1},
            slicer_settings=slicer,
            env=env or None,
            analyze=cache,
        )
    )
    data = out.read_bytes() if out.is_file() else inp.read_bytes()
    metrics = None
    if report is not None and (report / "metrics.json").is_file():
        metrics = json.loads((report / "metrics.json").read_text(encoding="utf-8"))
    beta, cov = metrics_summary(metrics) if metrics else (None, None)
    answer: dict[str, Any] = {
        "changed": result.changed,
        "warnings": list(result.warnings),
        "error_kept": result.error,
        "fea_cached": cache.hits > 0 and cache.misses == 0,
        "fea_solved": cache.misses,
        "times": {k: round(float(v), 4) for k, v in result.times.items()},
        "settings": result.settings.as_dict() if result.settings is not None else {},
        "metrics": metrics,
        "summary": {"beta": beta, "coverage": cov},
    }
    if binary:
        answer["gcode_base64"] = base64.b64encode(data).decode("ascii")
    else:
        answer["gcode"] = data.decode("utf-8", "surrogateescape")
    return answer


def _child(conn: Any, req: Mapping[str, Any], work: str, fea_dir: str, fea_entries: int, cache: str) -> None:
    """Run :func:`handle_run` in a child process; send ``("ok", answer)`` or ``("error", code, msg)``."""
    confine(Path(cache))
    from loadpath.errors import LoadpathError

    try:
        conn.send(("ok", handle_run(req, Path(work), Path(fea_dir), fea_entries)))
    except LoadpathError as exc:
        conn.send(("error", 422, "loadpath_error", " ".join(str(exc).split())))
    except MemoryError:
        conn.send(("error", 500, "internal", "out of memory; process a smaller file"))
    except Exception as exc:  # a bug: still an answer
        conn.send(
            ("error", 500, "internal", f"internal error ({type(exc).__name__}: {exc}); please report this")
        )
    finally:
        conn.close()


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
        self._ctx = multiprocessing.get_context(
            "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
        )
        if self._ctx.get_start_method() == "forkserver":
            self._ctx.set_forkserver_preload(["loadpath.plugin.job", "loadpath.pipeline", "loadpath.fea"])
        handler = type("Handler", (_Handler,), {"service": self})
        self.httpd = ThreadingHTTPServer((HOST, config.port), handler)
        self.httpd.daemon_threads = True
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
        """Stop serving and close the socket."""
        self.httpd.shutdown()
        self.httpd.server_close()

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
                target=_child,
                args=(
                    send,
                    req,
                    str(work),
                    str(self.cache_dir / "fea"),
                    self.config.fea_cache_entries,
                    str(self.cache_dir / "tmp"),
                ),
            )
            proc.start()
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

    def _check_origin(self) -> None:
        """Refuse requests addressed to another host name (DNS rebinding) or sent by a web page."""
        host = urlsplit("//" + (self.headers.get("Host") or "")).hostname
        if host not in _LOOPBACK:
            raise RequestError(
                403, "forbidden", f"Host {self.headers.get('Host')!r} is not this machine's loopback"
            )
        origin = self.headers.get("Origin")
        if origin is not None and urlsplit(origin).hostname not in _LOOPBACK:
            raise RequestError(403, "forbidden", f"requests from web pages ({origin}) are not accepted")

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
                        "fea_cache_entries": len(list((svc.cache_dir / "fea").glob("*.pickle"))),
                    },
                )
            elif self.path == "/v1/schema":
                from loadpath.plugin.settings import SCHEMA

                self._send(
                    200,
                    {
                        "ok": True,
                        "settings": {
                            f.name: {
                                "type": f.kind,
                                "default": list(f.default) if isinstance(f.default, tuple) else f.default,
                                "unit": f.unit,
                                "help": f.help,
                                "choices": list(f.choices),
                                "minimum": f.minimum,
                                "maximum": f.maximum,
                                "group": f.group,
                            }
                            for f in SCHEMA
                        },
                    },
                )
            else:
                raise RequestError(
                    404, "not_found", f"no {self.path}; use GET /v1/health, GET /v1/schema or POST /v1/run"
                )
        except RequestError as exc:
            self._error(exc)

    def do_POST(self) -> None:  # noqa: N802
        t0 = time.monotonic()
        svc = self.service
        if not svc.admit():
            self.close_connection = True
            self._error(
                RequestError(
                    503,
                    "busy",
                    f"{svc.config.workers} job(s) running and {svc.config.queue} waiting; retry later",
                )
            )
            return
        try:
            self._check_origin()
            if self.path != "/v1/run":
                raise RequestError(404, "not_found", f"no POST {self.path}; use POST /v1/run")
            ctype = (self.headers.get("Content-Type") or "").split(";")[0].strip().lower()
            if ctype != "application/json":
                raise RequestError(
                    415, "unsupported_media_type", "send the request as Content-Type: application/json"
                )
            length = self.headers.get("Content-Length")
            if length is None or not length.isdigit():
                raise RequestError(411, "length_required", "give the body's Content-Length")
            limit = int(svc.config.max_request_mb * 1e6)
            if int(length) > limit:
                self.close_connection = True
                raise RequestError(
                    413,
                    "too_large",
                    f"the request has {int(length) / 1e6:.1f} MB, more than the "
                    f"{svc.config.max_request_mb:g} MB allowed (loadpath serve --max-mb)",
                )
            try:
                req = json.loads(self.rfile.read(int(length)))
            except (ValueError, UnicodeDecodeError) as exc:
                raise RequestError(400, "bad_request", f"the body is not valid JSON ({exc})") from None
            answer = svc.run(_check_request(req), t0 + svc.config.timeout)
            self._send(200, {"ok": True, **answer})
        except RequestError as exc:
            self._error(exc)
        except (OSError, TimeoutError):
            self.close_connection = True  # the client went away or was too slow
        finally:
            svc.release()


def _version() -> str:
    from loadpath import __version__

    return __version__
