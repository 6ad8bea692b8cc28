# Copyright (c) loadpath contributors. MIT licence.
"""Run loadpath on Cura's G-code, out of process: the standard library only.

Cura's Python has no OSQP or gmsh (slicer-conventions.md §13), so the Cura plugin never imports
loadpath. It joins Cura's chunk list (header, start G-code, one chunk per ``;LAYER:``, end G-code)
with a separator comment line, writes it to a temporary file with Cura's resolved settings as JSON,
and runs ``loadpath run`` (or posts the same to ``loadpath serve``) with a timeout. The separator
is a comment between layers, outside every infill block, so loadpath keeps it byte for byte and the
result splits back into the same chunks. Any failure comes back as a one-line message for the user;
the chunks are then left as they were.

Used by ``scripts/LoadpathScript.py`` (Extensions > Post Processing > Modify G-Code) and by
``LoadpathInfill.py`` (the Extensions menu); neither contains logic of its own.

One file of about 500 lines on purpose: the Modify G-Code script is loaded by Cura as a loose file
and loads this module by its path, so everything the two shells share lives here (settings,
chunk joining, running the command or the service, the report summary).
"""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

__all__ = [
    "SEPARATOR",
    "CURA_KEYS",
    "Outcome",
    "RunnerError",
    "schema",
    "script_setting_data",
    "options_from",
    "stack_settings",
    "find_command",
    "write_stl",
    "edit_part",
    "start_editor",
    "join_chunks",
    "split_chunks",
    "process_chunks",
    "report_summary",
    "error_comment",
    "in_cura_terms",
    "user_message",
]

SEPARATOR = ";LOADPATH_CHUNK_SEPARATOR"
"""Comment line put between Cura's chunks and split on afterwards."""

PROCESSED = ";LOADPATH_PROCESSED"
"""Appended to the header chunk once processed: a list carrying it is not processed again."""

HERE = os.path.dirname(os.path.abspath(__file__))

# Cura settings passed to loadpath (--slicer-settings): widths, spacing, heights, flow, retraction,
# speeds, filament, and what makes a file unsuitable (vase mode, one-at-a-time).
CURA_KEYS = (
    "machine_nozzle_size",
    "material_diameter",
    "layer_height",
    "layer_height_0",
    "line_width",
    "wall_line_width_0",
    "wall_line_width_x",
    "skin_line_width",
    "infill_line_width",
    "infill_line_distance",
    "infill_sparse_density",
    "infill_pattern",
    "infill_sparse_thickness",
    "top_layers",
    "bottom_layers",
    "wall_line_count",
    "material_flow",
    "infill_material_flow",
    "skin_material_flow",
    "retraction_enable",
    "retraction_amount",
    "retraction_speed",
    "retraction_retract_speed",
    "retraction_prime_speed",
    "retraction_min_travel",
    "retraction_hop_enabled",
    "retraction_hop",
    "retraction_combing",
    "speed_travel",
    "speed_infill",
    "speed_topbottom",
    "speed_z_hop",
    "relative_extrusion",
    "machine_firmware_retract",
    "machine_gcode_flavor",
    "magic_spiralize",
    "print_sequence",
)

# The plugin's own settings, before the loadpath settings generated from loadpath's schema.
_OWN_SETTINGS = {
    "loadcase": {
        "label": "Load case file (.toml)",
        "type": "str",
        "default_value": "",
        "description": "Absolute path of the load case; empty: the one chosen in Extensions > "
        "Loadpath infill",
    },
    "loadpath_command": {
        "label": "loadpath command",
        "type": "str",
        "default_value": "",
        "description": "Full path of the 'loadpath' command in its virtual environment; "
        "empty: the one set in the menu, else 'loadpath' on PATH",
    },
    "service_url": {
        "label": "Service URL",
        "type": "str",
        "default_value": "",
        "description": "Address of 'loadpath serve' (e.g. http://127.0.0.1:8765); empty: run the command",
    },
    "timeout": {
        "label": "Timeout",
        "type": "int",
        "unit": "s",
        "default_value": 600,
        "minimum_value": "10",
        "description": "Give up after this long and keep the slicer's G-code",
    },
    "report": {
        "label": "Write a report",
        "type": "bool",
        "default_value": True,
        "description": "Keep an HTML report of the last run (Extensions > Loadpath infill > Show "
        "last report)",
    },
}


class RunnerError(Exception):
    """A failure to show to the user (one line: what went wrong and how to fix it)."""


class Outcome:
    """What a run produced.

    Attributes: ``ok``; ``chunks`` (the new chunk list, or the input when not ok); ``message`` (one
    line for the user); ``warnings`` (lines); ``report_dir`` (folder of the last report or None);
    ``seconds``; ``verdict`` (loadpath's one-line summary of what it replaced and gained, or "");
    ``changed`` (the chunks differ from Cura's: some infill was replaced).
    """

    def __init__(self, ok, chunks, message="", warnings=(), report_dir=None, seconds=0.0, verdict="", changed=False):
        self.verdict = verdict
        self.changed = changed
        self.ok = ok
        self.chunks = chunks
        self.message = message
        self.warnings = list(warnings)
        self.report_dir = report_dir
        self.seconds = seconds


# ---------------------------------------------------------------------------------------- settings


def schema():
    """loadpath's toolpath settings as Cura settings (``settings_schema.json``, generated from
    ``loadpath.plugin.settings.SCHEMA`` by ``scripts/build_curapackage.py``)."""
    with open(os.path.join(HERE, "settings_schema.json"), encoding="utf-8") as fh:
        return json.load(fh)["settings"]


def script_setting_data():
    """The ``getSettingDataString`` dictionary of the post-processing script."""
    settings = dict(_OWN_SETTINGS)
    settings.update(schema())
    return {
        "name": "Loadpath stress-aligned infill",
        "key": "LoadpathScript",
        "metadata": {},
        "version": 2,
        "settings": settings,
    }


def options_from(get):
    """loadpath settings that differ from loadpath's defaults, from ``get(key)`` (a Cura script's
    ``getSettingValueByKey`` or the plugin's preferences). Values left at their default are not
    passed, so the load case's ``[toolpath]`` table still applies."""
    out = {}
    for key, spec in schema().items():
        value = get(key)
        if value is None or value == "":
            continue
        default = spec["default_value"]
        if spec["type"] == "float":
            value = float(value)
            if key == "pitch" and value <= 0:
                continue  # 0: the slicer's own pitch
        elif spec["type"] == "int":
            value = int(value)
        elif spec["type"] == "bool":
            value = value if isinstance(value, bool) else str(value).strip().lower() in ("1", "true", "yes")
        else:
            value = str(value).strip()
        if value != default:
            out[key] = value
    return out


def stack_settings(global_stack, extruder_stacks=None, keys=CURA_KEYS):
    """Cura's resolved settings: ``{"global": {...}, "extruders": [{...}, ...]}``.

    ``global_stack`` and each extruder stack answer ``getProperty(key, "value")`` (Cura's
    ``GlobalStack`` / ``ExtruderStack``); the extruders default to ``global_stack.extruderList``.
    Keys a stack does not know are left out.
    """

    def read(stack):
        out = {}
        for key in keys:
            try:
                value = stack.getProperty(key, "value")
            except Exception:  # a stack without that setting (older/newer Cura)
                value = None
            if value is not None:
                out[key] = value if isinstance(value, (bool, int, float, str)) else str(value)
        return out

    if global_stack is None:
        return None
    if extruder_stacks is None:
        extruder_stacks = list(getattr(global_stack, "extruderList", []) or [])
    return {"global": read(global_stack), "extruders": [read(s) for s in extruder_stacks]}


# ---------------------------------------------------------------------------------------- chunks


def join_chunks(chunks):
    """One G-code text: the chunks with a separator line between them (``\\n`` endings added where
    missing, remembered in the returned flags)."""
    flags = [c.endswith("\n") for c in chunks]
    parts = []
    for k, c in enumerate(chunks):
        parts.append(c if flags[k] else c + "\n")
        if k < len(chunks) - 1:
            parts.append(SEPARATOR + "\n")
    return "".join(parts), flags


def split_chunks(text, flags):
    """Undo :func:`join_chunks` on processed text; raises :class:`RunnerError` when the separators
    did not survive."""
    parts = text.split("\n" + SEPARATOR + "\n")
    if len(parts) != len(flags):
        raise RunnerError(
            f"loadpath changed the separator lines between Cura's layers ({len(flags)} chunks, {len(parts)} "
            "back); the G-code was left unchanged: please report this"
        )
    out = []
    for k, p in enumerate(parts):
        if k < len(parts) - 1:
            p += "\n"
        if not flags[k] and p.endswith("\n"):
            p = p[:-1]
        out.append(p)
    return out


def error_comment(message):
    """A comment line for the top of the G-code (Cura swallows script exceptions: say it in the file)."""
    return ";LOADPATH FAILED: {} (the slicer's G-code below is unchanged)\n".format(
        " ".join(str(message).split())
    )


# ---------------------------------------------------------------------------------------- running


def find_command(configured=""):
    """The ``loadpath`` executable: the configured path, else ``loadpath`` on PATH or in
    ``~/.local/bin``; raises :class:`RunnerError` with how to fix it."""
    if configured:
        path = os.path.expanduser(configured)
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
        found = shutil.which(path)
        if found:
            return found
        raise RunnerError(
            f"the loadpath command {configured!r} does not exist or is not executable; give the full path "
            "of 'loadpath' in its virtual environment (e.g. /home/me/loadpath-venv/bin/loadpath)"
        )
    for candidate in (shutil.which("loadpath"), os.path.expanduser("~/.local/bin/loadpath")):
        if candidate and os.path.isfile(candidate) and os.access(candidate, os.X_OK):
            return candidate
    raise RunnerError(
        "the 'loadpath' command was not found: install loadpath in a virtual environment and set "
        "its full path in Extensions > Loadpath infill > loadpath command... (or the script's 'loadpath "
        "command')"
    )


_VERDICT = re.compile(r"^loadpath \S+ on \S+: ")


def verdict_line(text):
    """loadpath's verdict line in a run's stderr ("" when there is none)."""
    found = [ln.strip() for ln in text.splitlines() if _VERDICT.match(ln.strip())]
    return found[-1] if found else ""


def _last_line(text):
    lines = [
        ln.strip()
        for ln in text.splitlines()
        if ln.strip() and ": warning:" not in ln and not _VERDICT.match(ln.strip())
    ]
    if not lines:
        return ""
    line = lines[-1]
    return line.split(": ", 1)[1] if line.startswith("loadpath: ") else line


REPORT_LOST = "the report could not be written"
REPORT_LOST_GCODE = "the stress-aligned G-code was made without it"


def in_cura_terms(text, src, out, report):
    """loadpath's words about the files of a run, said of Cura's G-code.

    The runner's temporary copies (``src`` in, ``out`` out, ``report`` folder) are removed when the
    run ends and mean nothing to the user: a failure's closing words on them are dropped (the
    shells say that Cura's G-code is kept), the report's loss is said of the G-code Cura saves, and
    an output that could not be written is named by its folder (the temporary folder to free).
    """
    drop = (
        f"; the input {src!r} is untouched and {out!r} was not written",
        f"; {out!r} was written; the input {src!r} is untouched",
    )
    for words in drop:
        text = text.replace(words, "")
    if report:
        text = text.replace(f"{REPORT_LOST} to {report!r} (", f"{REPORT_LOST} (")
    text = text.replace(f"the G-code {out!r} was written", REPORT_LOST_GCODE)
    # what is left names the output only where it could not be written: say where that is
    return text.replace(repr(out), f"loadpath's temporary file in {os.path.dirname(os.path.dirname(out))!r}")


def _run(argv, timeout):
    """Run ``argv`` with a timeout, killing its whole process group on expiry; (status, stderr)."""
    kwargs = {"stdout": subprocess.DEVNULL, "stderr": subprocess.PIPE, "stdin": subprocess.DEVNULL}
    if sys.platform == "win32":
        info = subprocess.STARTUPINFO()
        info.dwFlags |= subprocess.STARTF_USESHOWWINDOW  # no console window
        kwargs["startupinfo"] = info
        kwargs["creationflags"] = subprocess.CREATE_NEW_PROCESS_GROUP
    else:
        kwargs["start_new_session"] = True
    proc = subprocess.Popen(argv, **kwargs)
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        if sys.platform == "win32":
            proc.kill()
        else:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise RunnerError(
            f"loadpath did not finish within {timeout:g} s; the G-code was left unchanged (raise the "
            "timeout, or use a coarser load case / fewer replaced layers)"
        ) from None
    return proc.returncode, err.decode("utf-8", "replace")


def _replace_dir(src, dst):
    if os.path.isdir(dst):
        old = dst + ".old"
        shutil.rmtree(old, ignore_errors=True)
        os.replace(dst, old)
        shutil.rmtree(old, ignore_errors=True)
    os.replace(src, dst)


def process_chunks(
    chunks,
    loadcase,
    options=None,
    command="",
    cura_settings=None,
    timeout=600.0,
    report_root=None,
    service_url="",
):
    """Run loadpath on Cura's chunk list.

    Parameters: ``chunks`` (list of str, Cura's ``gcode_dict`` entry); ``loadcase`` (path of the TOML
    file); ``options`` (loadpath settings, :func:`options_from`); ``command`` (the ``loadpath``
    executable, see :func:`find_command`); ``cura_settings`` (:func:`stack_settings`); ``timeout``
    (s); ``report_root`` (folder that receives ``last-report/``; None: no report); ``service_url``
    (use ``loadpath serve`` there instead of the command).

    Returns an :class:`Outcome`; never raises for a loadpath failure (the outcome says it).
    """
    t0 = time.monotonic()
    chunks = list(chunks)
    if report_root:  # whatever happens now, an earlier run's report is not this run's
        shutil.rmtree(os.path.join(report_root, "last-report"), ignore_errors=True)
    try:
        if not chunks:
            raise RunnerError("Cura gave no G-code to process; slice first")
        if not loadcase:
            raise RunnerError("no load case chosen: Extensions > Loadpath infill > Choose load case...")
        loadcase = os.path.expanduser(str(loadcase))
        if not os.path.isfile(loadcase):
            raise RunnerError(
                f"the load case {loadcase!r} does not exist; choose it again (Extensions > Loadpath infill "
                "> Choose load case)"
            )
        if service_url:
            return _via_service(
                chunks, loadcase, options or {}, cura_settings, timeout, report_root, service_url, t0
            )
        exe = find_command(command)
        text, flags = join_chunks(chunks)
        work = tempfile.mkdtemp(prefix="loadpath-cura-")
        try:
            src, out = os.path.join(work, "cura.gcode"), os.path.join(work, "cura.loadpath.gcode")
            with open(src, "w", encoding="utf-8", newline="") as fh:
                fh.write(text)
            argv = [exe, "run", src, "--loadcase", loadcase, "-o", out]
            if cura_settings:
                js = os.path.join(work, "cura_settings.json")
                with open(js, "w", encoding="utf-8") as fh:
                    json.dump(cura_settings, fh)
                argv += ["--slicer-settings", js]
            report_tmp = os.path.join(work, "report") if report_root else None
            if report_tmp:
                argv += ["--report", report_tmp]
            for key, value in sorted((options or {}).items()):
                argv += ["--set", f"{key}={str(value).lower() if isinstance(value, bool) else value}"]
            status, err = _run(argv, timeout)
            err = in_cura_terms(err, src, out, report_tmp)
            warnings = [
                ln.split(": warning: ", 1)[1].strip() for ln in err.splitlines() if ": warning: " in ln
            ]
            if status != 0:
                raise RunnerError(_last_line(err) or f"loadpath stopped with exit status {status}")
            with open(out, encoding="utf-8", newline="") as fh:
                new = split_chunks(fh.read(), flags)
            report_dir = None
            if report_tmp and os.path.isdir(report_tmp) and not any(w.startswith(REPORT_LOST) for w in warnings):
                try:
                    os.makedirs(report_root, exist_ok=True)
                    report_dir = os.path.join(report_root, "last-report")
                    _replace_dir(report_tmp, report_dir)
                except OSError as exc:  # the G-code is made: only the report is lost
                    report_dir = None
                    warnings.append(
                        f"{REPORT_LOST} into {report_root!r} ({exc.strerror or exc}); {REPORT_LOST_GCODE}"
                    )
        finally:
            shutil.rmtree(work, ignore_errors=True)
        return _done(chunks, new, "stress-aligned infill written", warnings, report_dir, t0, verdict_line(err))
    except RunnerError as exc:
        return Outcome(False, chunks, str(exc), (), None, time.monotonic() - t0)
    except OSError as exc:
        return Outcome(
            False,
            chunks,
            f"cannot run loadpath: {exc}; check the loadpath command and the temporary folder",
            (),
            None,
            time.monotonic() - t0,
        )


def _via_service(chunks, loadcase, options, cura_settings, timeout, report_root, url, t0):
    text, flags = join_chunks(chunks)
    with open(loadcase, encoding="utf-8") as fh:
        case_text = fh.read()
    body = json.dumps(
        {
            "gcode": text,
            "loadcase": case_text,
            # the service types settings strictly (GET /v1/schema): a list of kinds is a JSON list
            "settings": {k: [p.strip() for p in v.split(",") if p.strip()] if k == "replace" and
                         isinstance(v, str) else v for k, v in options.items()},
            "slicer_settings": cura_settings or {},
            "report": bool(report_root),
        }
    ).encode("utf-8")
    req = urllib.request.Request(
        url.rstrip("/") + "/v1/run", data=body, method="POST", headers={"Content-Type": "application/json"}
    )
    try:
        with urllib.request.urlopen(req, timeout=timeout) as resp:
            answer = json.loads(resp.read().decode("utf-8"))
    except urllib.error.HTTPError as exc:
        try:
            answer = json.loads(exc.read().decode("utf-8"))
            message = answer["error"]["message"]
        except (ValueError, KeyError, TypeError):
            message = f"HTTP {exc.code} {exc.reason}"
        raise RunnerError(message) from None
    except (urllib.error.URLError, OSError) as exc:
        raise RunnerError(
            "cannot reach the loadpath service at {} ({}); start it with 'loadpath serve' or "
            "clear the service URL".format(url, getattr(exc, "reason", exc))
        ) from None
    new = split_chunks(answer["gcode"], flags)
    report_dir = None
    if report_root and answer.get("metrics") is not None:  # null: the service could not make it
        report_dir = os.path.join(report_root, "last-report")
        tmp = tempfile.mkdtemp(prefix="report-", dir=_ensure(report_root))
        with open(os.path.join(tmp, "metrics.json"), "w", encoding="utf-8") as fh:
            json.dump(answer["metrics"], fh, indent=1)
        _replace_dir(tmp, report_dir)
    verdict = (answer.get("verdict") or {}).get("line", "")
    return _done(chunks, new, "stress-aligned infill written (service)", answer.get("warnings", []), report_dir,
                 t0, verdict)


def _done(chunks, new, note, warnings, report_dir, t0, verdict):
    """The outcome of a run that ended: processed chunks are marked; unchanged ones stay Cura's, unmarked."""
    changed = new != chunks
    if changed:
        new[0] += PROCESSED + "\n"
    return Outcome(True, new if changed else chunks, note if changed else "nothing replaced", warnings,
                   report_dir, time.monotonic() - t0, verdict, changed)


def user_message(outcome, limit=5):
    """What a Cura message says of ``outcome`` (both shells): what became of the G-code, first.

    A failure: the G-code is saved as Cura sliced it (with the failure as its first line); a run that
    replaced nothing says so; else the time, loadpath's verdict line and the first ``limit`` warnings.
    """
    if not outcome.ok:
        return "Loadpath failed; the G-code is saved as Cura sliced it (its first line says why): " + outcome.message
    head = (
        f"Stress-aligned infill written in {outcome.seconds:.0f} s."
        if outcome.changed
        else "Loadpath replaced nothing; the G-code is saved as Cura sliced it."
    )
    lines = [head, *([outcome.verdict] if outcome.verdict else [])]
    return "\n".join(lines + ["warning: " + w for w in outcome.warnings[:limit]])


def write_stl(path, triangles):
    """Write a binary STL of ``triangles`` (sequence of three (x, y, z) corners, mm, z up)."""
    import struct

    with open(path, "wb") as fh:
        fh.write(b"loadpath: Cura build plate".ljust(80, b" "))
        fh.write(struct.pack("<I", len(triangles)))
        for a, b, c in triangles:
            fh.write(struct.pack("<12fH", 0.0, 0.0, 0.0, *a, *b, *c, 0))
    return path


def edit_part(folder, chunks=None, triangles=None):
    """The file ``loadpath edit`` opens for a plate: its last G-code (chunks), else its meshes as STL."""
    _ensure(folder)
    if chunks:
        path = os.path.join(folder, "plate.gcode")
        with open(path, "w", encoding="utf-8", newline="") as fh:
            fh.write(join_chunks(chunks)[0])
        return path
    if triangles:
        return write_stl(os.path.join(folder, "plate.stl"), triangles)
    raise RunnerError("the build plate is empty: add the part (and slice it for its real layers) first")


def start_editor(command, part, loadcase, log_path):
    """Start ``loadpath edit PART --loadcase CASE`` in the background; it opens the browser itself.

    Returns the process; its first line in ``log_path`` is the editor's address.
    """
    argv = [find_command(command), "edit", part, "--loadcase", loadcase]
    log = open(log_path, "w", encoding="utf-8")  # noqa: SIM115 (the child keeps writing to it)
    kwargs = {"stdout": log, "stderr": subprocess.STDOUT, "stdin": subprocess.DEVNULL}
    if sys.platform == "win32":
        kwargs["creationflags"] = subprocess.CREATE_NEW_PROCESS_GROUP
    else:
        kwargs["start_new_session"] = True
    try:
        return subprocess.Popen(argv, **kwargs)
    finally:
        log.close()


def _ensure(folder):
    os.makedirs(folder, exist_ok=True)
    return folder


def report_summary(report_dir):
    """A few lines about the last run from its ``metrics.json`` (for a Cura message)."""
    path = os.path.join(report_dir or "", "metrics.json")
    if not report_dir or not os.path.isfile(path):
        return (
            "No report of the last run (none was run yet, or the last run failed or could not write "
            "its report; its message says which)."
        )
    with open(path, encoding="utf-8") as fh:
        m = json.load(fh)
    lines = [
        "{}: {}".format(
            m.get("source") or "last run",
            "infill replaced" if m.get("changed") else "unchanged ({})".format(m.get("passthrough")),
        )
    ]
    for layer in m.get("layers", []):
        new, old = layer.get("new") or {}, layer.get("old") or {}
        if "beta" in new:
            lines.append(
                "layers {}: beta {:.3f} (slicer {:.3f}), coverage {:.3f}".format(
                    ",".join(str(x) for x in layer.get("layers", [])[:6]),
                    new.get("beta", float("nan")),
                    old.get("beta", float("nan")),
                    new.get("coverage", float("nan")),
                )
            )
    lines += [f"warning: {w}" for w in m.get("warnings", [])[:5]]
    return "\n".join(lines)
