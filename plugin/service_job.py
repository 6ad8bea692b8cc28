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

__all__ = ["RequestError", "confine", "check_request", "handle_run", "in_service_terms", "child"]


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
            "XDG_STATE_HOME": home + "/.local/state",  # the verdict's run log (the answer carries it)
        }
    )
    tempfile.tempdir = str(cache_dir / "tmp")


FLTK_SYSTEM_PREFS = "/etc/fltk"
"""Where FLTK (under gmsh) keeps its system-wide preferences, rewritten at every ``gmsh.initialize``."""


def redirect_system_prefs(cache_dir: Path) -> bool:
    """Give this process a private ``/etc/fltk`` inside ``cache_dir`` (Linux, as root).

    gmsh's FLTK rewrites ``/etc/fltk/fltk.org/fltk.prefs`` at every ``gmsh.initialize`` when it may
    (as root; its per-user file follows HOME, which :func:`confine` points into the cache).  The job
    process gets its own mount namespace in which ``cache_dir/home/.etc-fltk`` is bind-mounted over
    ``/etc/fltk``, so those writes land in the cache and the system's file is left alone.  Returns
    whether it took effect: a process that is not root cannot write there anyway; a kernel or
    container that refuses the namespace, or a system without ``/etc/fltk`` (FLTK would create it the
    first time), leaves everything as it was.
    """
    import sys

    if not sys.platform.startswith("linux") or os.geteuid() != 0 or not os.path.isdir(FLTK_SYSTEM_PREFS):
        return False
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    clone_newns, ms_bind, ms_rec, ms_private = 0x20000, 4096, 0x4000, 1 << 18
    private = Path(cache_dir) / "home" / ".etc-fltk"
    private.mkdir(mode=0o700, exist_ok=True)
    if libc.unshare(clone_newns) != 0 or libc.mount(None, b"/", None, ms_rec | ms_private, None) != 0:
        return False
    return libc.mount(os.fsencode(private), FLTK_SYSTEM_PREFS.encode(), None, ms_bind, None) == 0


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
    fields = {f.name: f for f in SCHEMA}
    for key, value in req.get("settings", {}).items():
        why = _type_error(fields[key], value)
        if why:
            raise RequestError(400, "bad_request", f"setting {key!r} = {_shown(value)}: {why} (GET /v1/schema)")
    for key in ("gcode", "gcode_base64", "loadcase"):
        if key in req and not _encodable(req[key]):
            raise RequestError(400, "bad_request", f"{key!r} holds a lone surrogate (\\ud800-\\udfff), "
                               "which is no text; send UTF-8 text")
    if "name" in req:
        why = _name_error(req["name"])
        if why:
            raise RequestError(400, "bad_request", f"'name' {why}")
    if "report" in req and not isinstance(req["report"], bool):
        raise RequestError(400, "bad_request", "'report' must be true or false")
    for key in ("slicer_env",):
        for k, v in req.get(key, {}).items():
            if not isinstance(v, (str, int, float, bool)) or not _encodable(str(v)) \
                    or not _encodable(k) or "\0" in str(k) + str(v):
                raise RequestError(400, "bad_request", f"'{key}' values must be strings, numbers or text")
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


NAME_MAX = 200
"""Longest display name of a request, characters."""


def _shown(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _encodable(text: Any) -> bool:
    if not isinstance(text, str):
        return True
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _name_error(name: Any) -> str | None:
    """Why ``name`` is no display name of a G-code file (a name, never a path), or None."""
    if not isinstance(name, str):
        return "must be a string (the file's display name)"
    if not name.strip() or name.strip() in (".", ".."):
        return f"{_shown(name)} is no file name; give the G-code's display name such as 'part.gcode'"
    if len(name) > NAME_MAX:
        return f"has {len(name)} characters; give at most {NAME_MAX}"
    bad = next((c for c in name if c in "/\\\0" or ord(c) < 32 or 0xD800 <= ord(c) <= 0xDFFF), None)
    if bad is not None:
        return (f"holds {bad!r}: it is the file's display name, not a path; give the name alone "
                "such as 'part.gcode'")
    return None


def _type_error(f: Any, value: Any) -> str | None:
    """Why ``value`` is not of setting ``f``'s type in /v1/schema, or None (strict: no coercion)."""
    import math

    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if value is None:
        return "null is no value; leave the setting out to use its default"
    if f.kind == "bool":
        return None if isinstance(value, bool) else "must be true or false"
    if f.kind == "str":
        if not isinstance(value, str):
            return "must be a string"
        if f.choices and value not in f.choices:
            return f"must be one of {', '.join(f.choices)}"
        return None
    if f.kind == "kinds":
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            return f"must be a list of strings from {', '.join(f.choices)}"
        bad = [v for v in value if f.choices and v not in f.choices]
        return f"{', '.join(bad)} not among {', '.join(f.choices)}" if bad else None
    if f.kind == "int":
        if not isinstance(value, int) or isinstance(value, bool):
            return "must be a whole number"
    elif f.kind in ("float", "optional_float"):
        if not number or not math.isfinite(value):
            return "must be a finite number"
    if f.minimum is not None and value < f.minimum or f.maximum is not None and value > f.maximum:
        lo = "" if f.minimum is None else f"{f.minimum:g}"
        hi = "" if f.maximum is None else f"{f.maximum:g}"
        return f"must lie within {lo}..{hi}"
    return None


def handle_run(req: Mapping[str, Any], work: Path, fea_dir: Path, fea_entries: int) -> dict[str, Any]:
    """Run one request in folder ``work`` (created, not removed); the answer's JSON (without ``ok``).

    Raises
    ------
    LoadpathError
        The job failed (its one-line message goes to the client).
    """
    from loadpath.errors import LoadpathError, SettingsError
    from loadpath.plugin.batch import metrics_summary
    from loadpath.plugin.job import JobRequest, run_job

    binary = "gcode_base64" in req
    # 'name' is a display name, checked by check_request; the file in the job folder has a fixed name
    # (keeping the name's suffix only when it is a G-code suffix)
    suffix = Path(str(req.get("name") or "")).suffix.lower()
    inp = work / ("part" + (suffix if suffix in (".gcode", ".bgcode", ".gco", ".g") else
                            ".bgcode" if binary else ".gcode"))
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
    try:
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
    except LoadpathError as exc:
        exc.args = (in_service_terms(str(exc), inp, out, report),)
        raise
    warnings = [in_service_terms(w, inp, out, report) for w in result.warnings]
    data = out.read_bytes() if out.is_file() else inp.read_bytes()
    metrics = None
    lost = any(w.startswith(REPORT_LOST) for w in warnings)  # a part of it may be on disk: none is shown
    if report is not None and not lost and (report / "metrics.json").is_file():
        metrics = json.loads((report / "metrics.json").read_text(encoding="utf-8"))
    beta, cov = metrics_summary(metrics) if metrics else (None, None)
    answer: dict[str, Any] = {
        "changed": result.changed,
        "warnings": warnings,
        "error_kept": result.error,
        "fea_cached": cache.stats.hits.get("fea", 0) > 0 and cache.stats.kept.get("fea", 0) == 0,
        "fea_solved": cache.stats.kept.get("fea", 0),
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


REPORT_LOST = "the report could not be written"


def in_service_terms(text: str, inp: Path, out: Path, report: Path | None) -> str:
    """A job's words about its files (:func:`loadpath.plugin.job_record.fate`), said of the request.

    The job's folder is the service's own and removed with the answer: a failure says that no
    G-code is returned (the client's G-code is its own, never changed), or with ``on_failure = keep``
    that the answer's G-code is the request's; a report that could not be
    written says that the answer's G-code is processed all the same, without the report's metrics;
    an output that could not be written is named by the service's cache folder (the one to free).
    """
    from loadpath.plugin.job_record import fate

    text = text.replace(fate(inp, out, False), "no G-code is returned").replace(
        f"{str(out)!r} is a copy of the slicer's G-code; the input is untouched",  # on_failure = keep
        "the G-code in this answer is the request's, unchanged",
    )
    if report is not None:
        text = text.replace(f"{REPORT_LOST} to {str(report)!r} (", f"{REPORT_LOST} (").replace(
            f"the G-code {str(out)!r} was written", "the G-code in this answer is processed all the same; "
            "'metrics' is null"
        )
    cache = out.parent.parent.parent  # CACHE/jobs/<id>/out.gcode
    return text.replace(repr(str(out)), f"the job's working copy in {str(cache)!r}")


def child(conn: Any, req: Mapping[str, Any], work: str, fea_dir: str, fea_entries: int, cache: str) -> None:
    """Run :func:`handle_run` in a child process; send ``("ok", answer)`` or ``("error", code, msg)``."""
    from loadpath.procs import worker_init

    worker_init()  # dies with the service (its forkserver), ignores the terminal's Ctrl-C
    confine(Path(cache))
    redirect_system_prefs(Path(fea_dir).parent)  # the service's cache folder: fea/, jobs/, tmp/, home/
    from loadpath.errors import InternalError, LoadpathError

    try:
        conn.send(("ok", handle_run(req, Path(work), Path(fea_dir), fea_entries)))
    except InternalError as exc:  # a bug or lack of memory met by the job: the service's failure
        conn.send(("error", 500, "internal", " ".join(str(exc).split())))
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
