"""Helpers for the end-to-end tests: a load case for any test part, and one job run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from loadpath import gcode
from loadpath.plugin.job import JobRequest, run_job

PULL = """version = 1
{extra}
[[supports]]
name = "clamp"
where = {{ side = "{a}_min", within = {within} }}
fix = ["x", "y", "z"]

[[loads]]
name = "pull"
where = {{ side = "{a}_max", within = {within} }}
force = [{fx}, {fy}, 0.0]
"""

BASE = """version = 1
{extra}
[[supports]]
name = "bed"
where = {{ side = "z_min", within = 0.05 }}
fix = ["x", "y", "z"]

[[loads]]
name = "pull"
where = {{ side = "x_max", within = {within} }}
force = [200.0, 0.0, 0.0]
"""


def write_case(
    folder: Path,
    name: str = "case.toml",
    within: float = 5.0,
    extra: str = "",
    axis: str = "x",
    base: bool = False,
) -> Path:
    """A tension load case: clamped at the axis' min side, pulled at its max side.  ``base``: held by its
    bottom face instead (every piece of a part with several pieces is then held)."""
    path = Path(folder) / name
    if base:
        text = BASE.format(within=within, extra=extra)
    else:
        text = PULL.format(
            within=within,
            extra=extra,
            a=axis,
            fx=500.0 if axis == "x" else 0.0,
            fy=500.0 if axis == "y" else 0.0,
        )
    path.write_text(text, encoding="utf-8")
    return path


def run(gcode_path: Path, case: Path, out: Path, **cli):
    """Run one job with the streamlines engine unless told otherwise; returns (program, result, output)."""
    cli = {"engine": "streamlines", "jobs": 1, **cli}
    program = gcode.read(gcode_path)
    result = run_job(JobRequest(Path(gcode_path), case, output=out, cli=cli))
    output = gcode.read(out) if out.exists() and out.suffix != ".bgcode" else None
    return program, result, output


def new_lines(result, program) -> np.ndarray:
    """(n_out,) bool: output lines written by the splicer."""
    sres = result.pipeline.splice
    lmap = sres.line_map(program.n_lines)
    out = result.pipeline.output
    mask = np.ones(out.n_lines, dtype=bool)
    mask[lmap[lmap >= 0]] = False
    return mask


def replaced_blocks(result) -> set[int]:
    """Indices (in the original program) of the blocks the run replaced."""
    return (
        {b.block for b in result.pipeline.splice.blocks}
        if result.pipeline and result.pipeline.splice
        else set()
    )


def span_lines_kept(program, output, result, block: int) -> bool:
    """Whether every line of a block's span is in the output unchanged."""
    b = program.block(block)
    lmap = (
        result.pipeline.splice.line_map(program.n_lines)
        if result.pipeline.splice
        else np.arange(program.n_lines)
    )
    idx = range(b.span_start, b.span_stop)
    return all(lmap[i] >= 0 and program.line(i) == output.line(int(lmap[i])) for i in idx)
