"""Property-based tests (hypothesis): lossless round trip and the machine-state semantics.

The state semantics are checked against a deliberately plain per-line interpreter written here
(``_reference``), independent of the vectorized implementation.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from loadpath import gcode

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _num(value: float, decimals: int, style: str) -> str:
    text = f"{value:.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    if style == "prusa" and text.startswith(("0.", "-0.")):
        text = text.replace("0.", ".", 1)  # PrusaSlicer writes .5 and -.04
    return text if text not in ("-0", "") else "0"


numbers = st.tuples(
    st.floats(-500, 500, allow_nan=False), st.integers(0, 5), st.sampled_from(["prusa", "cura"])
)


@st.composite
def motion_line(draw):
    cmd = draw(st.sampled_from(["G0", "G1", "G1", "G1"]))
    letters = draw(st.lists(st.sampled_from("XYZEF"), min_size=1, max_size=5, unique=True))
    words = []
    for c in letters:
        v, d, style = draw(numbers)
        if c == "F":
            v = abs(v) * 20 + 1
        words.append(c + _num(v, d, style))
    sep = draw(st.sampled_from([" ", " ", "  "]))
    return cmd + " " + sep.join(words)


other_lines = st.sampled_from(
    [
        "",
        " ",
        ";LAYER_CHANGE",
        ";Z:0.2",
        ";TYPE:Internal infill",
        ";WIDTH:0.45",
        "M204 S800",
        "M73 P12 R3",
        "M106 S255",
        "; comment with ünïcödé ✓",
        "G4 P100",
        "T0",
        'M862.3 P "MK3S"',
        "G28 W",
        "M117 hello;world",
        "EXCLUDE_OBJECT_START NAME=part_1",
        "G1 F1200",
        "   G1 X1 Y2   ; indented",
        "G1 X3 Y4 E.5 ; trailing comment",
    ]
)


@SETTINGS
@given(
    lines=st.lists(st.one_of(motion_line(), other_lines), min_size=1, max_size=60),
    ending=st.sampled_from(["\n", "\r\n"]),
    last_newline=st.booleans(),
    trailing=st.sampled_from(["", " ", "\t"]),
)
def test_round_trip_on_generated_lines(lines, ending, last_newline, trailing):
    text = ending.join(line + trailing for line in lines) + (ending if last_newline else "")
    if not text.strip():
        return
    data = text.encode("utf-8")
    program = gcode.parse(data, strict=False)
    assert program.to_bytes() == data
    expected = text.split(ending)
    if text.endswith(ending):
        expected = expected[:-1]
    assert program.n_lines == len(expected)
    assert [program.line(i) for i in range(program.n_lines)] == expected
    assert b"".join(program.lines_bytes(i, i + 1) for i in range(program.n_lines)) == data


@st.composite
def state_program(draw):
    out = []
    for _ in range(draw(st.integers(1, 40))):
        kind = draw(st.sampled_from(["move", "move", "move", "move", "G90", "G91", "M82", "M83", "G92"]))
        if kind == "move":
            out.append(draw(motion_line()))
        elif kind == "G92":
            axes = draw(st.lists(st.sampled_from("XYZE"), max_size=4, unique=True))
            out.append("G92" + "".join(f" {c}{_num(*draw(numbers))}" for c in axes))
        else:
            out.append(kind)
    return out


def _reference(lines):
    """Plain interpreter: state after each line (x, y, z, e, de, f)."""
    pos = {"X": 0.0, "Y": 0.0, "Z": 0.0, "E": 0.0}
    f, absolute, e_rel_latch = math.nan, True, False
    rows = []
    for line in lines:
        code = line.split(";")[0].split()
        de = 0.0
        if code:
            cmd, words = code[0], {w[0]: float(w[1:]) for w in code[1:]}
            if cmd == "G90":
                absolute = True
            elif cmd == "G91":
                absolute = False
            elif cmd == "M82":
                e_rel_latch = False
            elif cmd == "M83":
                e_rel_latch = True
            elif cmd == "G92":
                for c in words or dict.fromkeys("XYZE", 0.0):
                    pos[c] = words.get(c, 0.0)
            elif cmd in ("G0", "G1"):
                for c in "XYZ":
                    if c in words:
                        pos[c] = words[c] if absolute else pos[c] + words[c]
                if "E" in words:
                    rel = e_rel_latch or not absolute
                    de = words["E"] if rel else words["E"] - pos["E"]
                    pos["E"] = pos["E"] + words["E"] if rel else words["E"]
                if "F" in words:
                    f = words["F"]
        rows.append((pos["X"], pos["Y"], pos["Z"], pos["E"], de, f))
    return np.array(rows)


@SETTINGS
@given(lines=state_program())
def test_state_matches_a_plain_interpreter(lines):
    program = gcode.parse("\n".join(lines) + "\n", strict=False)
    ref = _reference(lines)
    s = program.state
    got = np.c_[s.x, s.y, s.z, s.e, s.de, s.f]
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9, equal_nan=True)


@SETTINGS
@given(lines=state_program())
def test_extruded_length_is_the_same_in_both_e_modes(lines):
    """Rewrite the same extrusions in relative and in absolute E: filament per move must agree."""
    steps = [float(_num(*t)) for t in [(0.1 * (i % 7) - 0.2, 3, "prusa") for i in range(len(lines))]]
    rel = ["G90", "M83"] + [f"G1 X{i} Y{i % 3} E{_num(d, 5, 'prusa')}" for i, d in enumerate(steps)]
    e, ab = 0.0, ["G90", "M82", "G92 E0"]
    for i, d in enumerate(steps):
        e += d
        ab.append(f"G1 X{i} Y{i % 3} E{e:.5f}")
    pr = gcode.parse("\n".join(rel) + "\n", strict=False).moves
    pa = gcode.parse("\n".join(ab) + "\n", strict=False).moves
    np.testing.assert_allclose(pa["e"], pr["e"], atol=2e-5)
    np.testing.assert_array_equal(pa["extrude"], pr["extrude"])


@SETTINGS
@given(lines=state_program())
def test_modal_feedrate_is_the_last_f_seen(lines):
    program = gcode.parse("\n".join(lines) + "\n", strict=False)
    last = math.nan
    for i, line in enumerate(lines):
        code = line.split(";")[0].split()
        if code and code[0] in ("G0", "G1"):
            for w in code[1:]:
                if w[0] == "F":
                    last = float(w[1:])
        f = program.state.f[i]
        assert (math.isnan(last) and math.isnan(f)) or f == last
