"""Lean numbers (issue 17): the new extrusion moves' X/Y to 2 decimals and relative E to 4, exactly
(``SpliceOptions.xy_decimals`` / ``e_decimals``; off by default: the slicer's 3 and 5 keep a 40 %
bar's predicted failure load, see their docstring).

Spliced into real PrusaSlicer 2.5 and CuraEngine 4.13 files (relative and absolute E): every new
extrusion moves the nozzle (a vertex that rounds onto the one before is merged, not written as an
E-only move), X and Y carry at most ``SpliceOptions.xy_decimals`` decimals except each chain's last
vertex (written as the slicer writes, so the travel after it starts where it was planned), relative
E words at most ``e_decimals`` except each chain's last (which rounds the running total to 5), and
the filament read back from the text is the plan's.  The same splice with the slicer's decimals is
larger.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from loadpath import gcode
from splice_helpers import SLICED_CASES, infill_blocks, rectilinear_fills, run_splice


def _decimals(word: str) -> int:
    return len(word.split(".")[1]) if "." in word else 0


@pytest.mark.parametrize("case", ["prusa-relE", "prusa-absE", "cura-relE", "cura-absE"])
def test_new_moves_are_written_lean_and_exact(sliced, case):
    slicer, part, settings, overrides = SLICED_CASES[case]
    program = gcode.read(sliced(slicer, part, settings, **overrides))
    fills = rectilinear_fills(program, infill_blocks(program)[:3])
    # tilted lines: their vertices are not on the slicer's grid, so the rounding is exercised
    result, out, check = run_splice(program, fills, options={"xy_decimals": 2, "e_decimals": 4})
    assert check.problems == []
    lean = len(result.data)
    result3, _, check3 = run_splice(program, fills)  # the default: the slicer's 3 and 5 decimals
    assert check3.problems == [] and lean < len(result3.data)
    lmap = result.line_map(program.n_lines)
    new = np.ones(out.n_lines, dtype=bool)
    new[lmap[lmap >= 0]] = False
    m = out.moves
    ext = m[m["extrude"] & new[m["line"]]]
    assert len(ext) > 100
    # every new extrusion moves in XY
    assert np.all(np.hypot(ext["x1"] - ext["x0"], ext["y1"] - ext["y0"]) > 0)
    # decimals: a chain's last move is followed by a line that is not an extrusion
    lines = [out.line(int(i)) for i in ext["line"]]
    nxt = np.isin(ext["line"] + 1, ext["line"])
    relative = bool(program.state.e_relative[program.block(fills[0].block).start])
    for ln, inner in zip(lines, nxt.tolist(), strict=True):
        words = dict((w[0], w[1:]) for w in ln.split(";")[0].split()[1:])
        if inner:
            assert _decimals(words["X"]) <= 2 and _decimals(words["Y"]) <= 2, ln
            if relative and "E" in words:
                assert _decimals(words["E"]) <= 4, ln
        assert _decimals(words["X"]) <= 3 and _decimals(words.get("E", "0")) <= 5, ln
    # the filament read back is what the plan asked for, to the slicer's rounding
    for r in result.blocks:
        got = check.volume_ratio[r.block] * program.block(r.block).e
        assert got == pytest.approx(r.filament_new, abs=1e-4)


def test_relative_e_words_carry_their_rounding():
    """Many short moves: E to 4 decimals each, their sum to the total asked for (to 5 decimals)."""
    from loadpath.splice.emit import STYLES, Writer

    style = dataclasses.replace(STYLES["prusa"], path_xy_decimals=2, e_decimals=4)
    w = Writer(style, 0.0, 0.0, 0.2, 0.0, 1800.0, True)
    rng = np.random.default_rng(3)
    n = 500
    pts = np.c_[np.cumsum(rng.uniform(0.2, 2.0, n + 1)), rng.uniform(-0.01, 0.01, n + 1)]
    pts[0] = 0.0
    de = rng.uniform(0.001, 0.08, n)
    w.extrude_many(pts, de, np.full(n, 1800.0))
    es = [float(x) for x in re.findall(r" E(-?[0-9.]+)", w.text())]
    assert max(_decimals(str(e)) for e in es[:-1]) <= 4
    assert sum(es) == pytest.approx(de.sum(), abs=5e-6 + 1e-9)
