"""G2/G3 arcs as geometry (Marlin semantics), on hand-written moves with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from loadpath import gcode
from loadpath.tolerances import TOL


def _arc_moves(text: str) -> np.ndarray:
    p = gcode.parse("G90\nM83\nG1 X10 Y0 Z0.2 F600\n" + text, strict=False)
    return p.moves[p.moves["arc"]]


def _length(m: np.ndarray) -> float:
    return float(np.hypot(m["x1"] - m["x0"], m["y1"] - m["y0"]).sum())


@pytest.mark.parametrize(
    "cmd,end,sweep",
    [
        ("G3", (0, 10), math.pi / 2),
        ("G2", (0, 10), 3 * math.pi / 2),
        ("G3", (-10, 0), math.pi),
        ("G2", (0, -10), math.pi / 2),
    ],
)
def test_quarter_half_and_three_quarter_circles(cmd, end, sweep):
    m = _arc_moves(f"{cmd} X{end[0]} Y{end[1]} I-10 J0 E1\n")
    r = np.hypot(m["x1"], m["y1"])
    np.testing.assert_allclose(r, 10.0, atol=1e-12)  # every vertex on the circle around (0, 0)
    assert (m["x1"][-1], m["y1"][-1]) == end
    chord = 2 * 10 * math.sin(sweep / len(m) / 2)
    assert _length(m) == pytest.approx(len(m) * chord)
    # chords within 0.005 mm of the arc are shorter by about (2/3) * sagitta / radius
    assert _length(m) == pytest.approx(10 * sweep, rel=(2 / 3) * TOL.arc_chord_mm / 10 * 1.1)
    sag = 10 - math.sqrt(100 - (chord / 2) ** 2)
    assert sag <= TOL.arc_chord_mm
    assert m["e"].sum() == pytest.approx(1.0) and (m["e"] > 0).all()
    np.testing.assert_allclose(np.diff(m["e"]), 0, atol=1e-15)  # E spread along the sweep
    # direction: G3 turns left (counter-clockwise), G2 right
    cross = m["x0"] * m["y1"] - m["y0"] * m["x1"]
    assert (np.sign(cross) == (1 if cmd == "G3" else -1)).all()


def test_full_circle_when_the_end_is_the_start():
    m = _arc_moves("G2 X10 Y0 I-10 J0 E2\n")
    assert _length(m) == pytest.approx(2 * math.pi * 10, rel=4e-4)
    assert m["e"].sum() == pytest.approx(2.0)


def test_radius_form_picks_the_short_or_long_arc():
    short = _arc_moves("G3 X0 Y10 R10\n")
    long = _arc_moves("G3 X0 Y10 R-10\n")
    assert _length(short) == pytest.approx(10 * math.pi / 2, rel=4e-4)
    assert _length(long) == pytest.approx(10 * 3 * math.pi / 2, rel=4e-4)
    assert short["travel"].all() and not short["extrude"].any()


def test_helical_arc_interpolates_z():
    m = _arc_moves("G3 X0 Y10 Z1.2 I-10 J0 E1\n")
    assert m["z0"][0] == 0.2 and m["z1"][-1] == 1.2
    assert (np.diff(m["z1"]) > 0).all()
    assert m["extrude"].all() and not m["lift"].any()  # lift flags only moves that do not extrude
