"""One request of ``loadpath serve``, run in a child process confined to the service's cache folder.

:func:`check_request` validates a ``POST /v1/run`` body's shape, :func:`handle_run` turns it into a
:class:`~loadpath.plugin.job.JobRequest` over files in the request's own working folder (with the
cache of analyses and paths, :mod:`loadpath.cache`), and :func:`child` runs it in a child process
and sends back the answer or the error.
"""

from __future__ import annotations

import base64
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["RequestError", "confine", "check_request", "handle_run", "child"]


class RequestError(Exception):
    """A request that gets an error answer: HTTP status, code, one-line message."""

    def __init__(self, status: int, code: str, message: str) -> None:
        super().__init__(message)
        self.status, self.code, self.message = status, code, message


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


def check_request(req: Any) -> dict[str, Any]:
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
        - {
            "gcode",
            "gcode_base64",
            "loadcase",
            "settings",
            "slicer_settings",
            "slicer_env",
            "name",
            "report",
            "force",
        }
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
    from loadpath.cache import Cache

    cache = Cache(fea_dir, max_entries=fea_entries)
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
            cache=cache,
            force=req.get("force") is True,
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
        "fea_cached": cache.stats.hits.get("fea", 0) > 0 and cache.stats.misses.get("fea", 0) == 0,
        "fea_solved": cache.stats.misses.get("fea", 0),
        "times": {k: round(float(v), 4) for k, v in result.times.items()},
        "settings": result.settings.as_dict() if result.settings is not None else {},
        "metrics": metrics,
        "summary": {"beta": beta, "coverage": cov},
        "verdict": result.verdict.as_dict() if result.verdict is not None else None,
    }
    if binary:
        answer["gcode_base64"] = base64.b64encode(data).decode("ascii")
    else:
        answer["gcode"] = data.decode("utf-8", "surrogateescape")
    return answer


def child(conn: Any, req: Mapping[str, Any], work: str, fea_dir: str, fea_entries: int, cache: str) -> None:
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
