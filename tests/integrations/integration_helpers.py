"""Helpers for the slicer-integration tests: a load case, the reference run and the splicer's checks.

The integrations (PrusaSlicer hook, Cura script, service, batch) are thin shells over
:func:`loadpath.plugin.job.run_job`.  Their output files are checked the way the splicer's own
tests check a splice: the same input is run once in-process (the *reference*), which gives the
splice's edits; the shell's output must be that output byte for byte, and
:func:`loadpath.splice.verify.check_splice` on the shell's file (parsed from disk) must find no
problem: every line outside the replaced blocks unchanged, machine state on kept lines, volume of
each replaced block within 3 %, retraction bounds, absolute E continuity, same layers and features,
new extrusions inside their regions.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from fixtures import without_verdict

from loadpath import gcode
from loadpath.splice.verify import check_splice
from loadpath.plugin.job import JobRequest, run_job

REPO = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.executable).parent
RUNNER = REPO / "cura_plugin" / "LoadpathInfill" / "loadpath_runner.py"

CASE = """version = 1
[material]
youngs_modulus = 3500.0
poissons_ratio = 0.35

[[supports]]
name = "clamp"
where = {{ side = "x_min", within = {within} }}
fix = ["x", "y", "z"]

[[loads]]
name = "pull"
where = {{ side = "x_max", within = {within} }}
force = [1000.0, 0.0, 0.0]
"""

FAST = {"engine": "streamlines", "jobs": 1}
"""Settings for quick runs: the streamline engine, one worker."""


def write_case(folder: Path, name: str = "case.toml", within: float = 10.0) -> Path:
    """The specimen's load case: clamped at its small-x end, pulled with 1000 N at the other."""
    path = Path(folder) / name
    path.write_text(CASE.format(within=within), encoding="utf-8")
    return path


def write_bad_case(folder: Path) -> Path:
    """A load case with no load (a one-line LoadCaseError)."""
    path = Path(folder) / "bad.toml"
    path.write_text(
        'version = 1\n[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 10.0 }\n'
        'fix = ["x", "y", "z"]\n',
        encoding="utf-8",
    )
    return path


def reference(original: Path, case: Path, out: Path, cli: dict | None = None, **kw):
    """The in-process run of the same input (the splice the shell's output must equal)."""
    result = run_job(
        JobRequest(Path(original), Path(case), output=Path(out), cli={**FAST, **(cli or {})}, **kw)
    )
    assert result.error is None and result.changed, (result.error, result.warnings)
    return result


def assert_spliced(original: Path, output: bytes, ref) -> None:
    """``output`` is the reference's output and passes the splicer's checks against ``original``."""
    assert without_verdict(output) == without_verdict(Path(ref.output).read_bytes()), (
        "the shell's output differs from the same run in-process"
    )
    assert output.count(b"\n; loadpath: loadpath ") == 1, "no verdict line in the header"
    prog = gcode.read(original)
    out = gcode.parse(output, strict=False)
    pres = ref.pipeline
    regions = None
    check = check_splice(prog, out, pres.splice, volume_tol=0.03, regions=regions)
    assert check.problems == [], check.problems[:3]
    assert pres.splice.blocks, "nothing was replaced"
    ratios = list(check.volume_ratio.values())
    assert ratios and all(abs(r - 1.0) <= 0.03 for r in ratios), ratios


# ------------------------------------------------------------------------------------- Cura

_TOKEN = re.compile(r'-s (\w+)="([^"\n]*)"|(?<=\s)(-e\d+|-g)(?=\s)')


def cura_engine_settings(stderr: str) -> dict:
    """Cura's resolved settings as CuraEngine prints them (``[WARNING]  -s key="value" ...``): the
    global section, then one per extruder (``-e0``); mesh sections (``-g``) end the listing."""
    start = stderr.find("[WARNING]  -s ")
    assert start >= 0, "CuraEngine printed no settings listing"
    glob: dict[str, str] = {}
    extruders: list[dict[str, str]] = []
    current = glob
    for m in _TOKEN.finditer(stderr, start):
        if m.group(3):
            if m.group(3) == "-g":
                break
            extruders.append({})
            current = extruders[-1]
        else:
            current[m.group(1)] = m.group(2)
    return {"global": glob, "extruders": extruders}


def cura_chunks(text: str) -> list[str]:
    """A saved Cura file split the way Cura hands it to post-processing scripts (§11.4): the
    header, the start G-code, one chunk per ``;LAYER:``, the end G-code."""
    gen = text.index(";Generated with Cura_SteamEngine")
    head, rest = text[:gen], text[gen:]
    layers = re.split(r"(?m)^(?=;LAYER:-?\d+)", rest)
    start, layers = layers[0], layers[1:]
    last = layers[-1]
    tail = [m.end() for m in re.finditer(r"(?m)^;TIME_ELAPSED:[^\n]*\n", last)]
    end = last[tail[-1] :] if tail else ""
    layers[-1] = last[: tail[-1]] if tail else last
    return [head, start, *layers, end]
