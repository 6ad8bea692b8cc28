"""verify.check_output (the check from the output's bytes, no second Program) against check_splice.

The pipeline checks every file it writes with :func:`check_output`; it must find exactly what
:func:`check_splice` on the fully parsed output finds, on real PrusaSlicer 2.5 and CuraEngine 4.13
files (relative and absolute E, firmware retraction, volumetric E, two objects), for a good splice
and for spliced files damaged in each way the check looks for.
"""

from __future__ import annotations

import numpy as np
import pytest
from loadpath import gcode
from loadpath.gcode.blocks import EXTRUDE
from loadpath.splice.lineview import read_lines
from loadpath.splice.piecewise import _cuts
from loadpath.splice.verify import check_output, check_splice, layer_features
from splice_helpers import SLICED_CASES, infill_blocks, rectilinear_fills, run_splice

# every real case of the splice tests but the second Cura part
CASES = {k: v for k, v in SLICED_CASES.items() if k != "cura-two-objects"}


@pytest.fixture(scope="module", params=list(CASES), ids=list(CASES))
def spliced(request, sliced):
    slicer, part, settings, overrides = CASES[request.param]
    program = gcode.read(sliced(slicer, part, settings, **overrides))
    fills = rectilinear_fills(program, infill_blocks(program))
    result, out, check = run_splice(program, fills)
    regions = {f.block: f.region for f in fills if f.region is not None}
    return program, result, out, check, regions


def _same(a, b):
    assert a.problems == b.problems
    assert a.volume_ratio == b.volume_ratio  # exactly: the same sums of the same numbers
    assert a.outside_mm == b.outside_mm


def test_line_view_holds_the_programs_arrays(spliced):
    """Every array the check reads is the parsed Program's, bit for bit."""
    program, result, out, _, _ = spliced
    view = read_lines(result.data)
    assert view.n_lines == out.n_lines and view.dialect == out.dialect and view.n_layers == len(out.layers)
    for name in ("cmd", "x", "y", "z", "e", "de", "f", "absolute_xyz", "e_relative", "moved_xy"):
        assert np.array_equal(getattr(view.state, name), getattr(out.state, name), equal_nan=name == "f"), (
            name
        )
    for name in ("fw_retracted", "retracted", "tool"):
        assert np.array_equal(getattr(view.state, name), getattr(out.state, name)), name
    assert np.array_equal(view.kind_of_line, out.kind_of_line)
    assert view.layer_features() == layer_features(out)
    n_ext = 0
    for rep in result.blocks:
        for a, z in result.output_ranges(program, rep.block):
            mv = out.moves[out.move_rows(a, z)]
            mv = mv[mv["extrude"]]
            ext = view.extrusions(a, z)
            assert len(ext) == len(mv)
            n_ext += len(ext)
            for f in ext.dtype.names:
                assert np.array_equal(ext[f], mv[f], equal_nan=True), f
    assert n_ext > 0


# (piece_lines, groups, workers): whole; in pieces of 150 lines (a few dozen, cut between layers);
# those pieces in three groups read one after the other, each but the first from a guessed start;
# in two groups read side by side in forked processes; by default
READS = {
    "whole": (0, None, 1),
    "pieces": (150, None, 1),
    "groups": (150, 3, 1),
    "forked": (150, 2, 2),
    "default": (None, None, 1),
}


@pytest.mark.parametrize("read", list(READS))
def test_same_verdict_on_a_good_splice(spliced, read):
    piece_lines, groups, workers = READS[read]
    program, result, out, check, regions = spliced
    assert check.problems == []
    if piece_lines:  # the pieces really are several
        assert len(_cuts(program, result.line_map(program.n_lines), out.n_lines, piece_lines)) >= 3
    got = check_output(
        program, result.data, result, regions=regions, piece_lines=piece_lines, workers=workers, groups=groups
    )
    _same(got, check)


def _damage(program, result, out, how):
    """The output's bytes with one defect of the kind the check looks for."""
    lmap = result.line_map(program.n_lines)
    kept = np.flatnonzero(lmap >= 0)
    new = np.ones(out.n_lines, dtype=bool)
    new[lmap[kept]] = False
    lines = result.data.split(b"\n")
    first_new_extrusion = next(
        i for i in np.flatnonzero(new) if out.kind_of_line[i] == EXTRUDE and b" E" in lines[i]
    )
    if how == "kept line":
        j = int(lmap[kept[len(kept) // 2]])
        lines[j] = lines[j] + b" ; edited"
    elif how == "volume":  # every new extrusion pushes 10 % more
        for i in np.flatnonzero(new & (out.kind_of_line == EXTRUDE)):
            head, e = lines[i].rsplit(b" E", 1)
            lines[i] = head + b" E" + f"{float(e.split()[0]) * 1.1:.5f}".encode()
    elif how == "retraction":  # a new line pulls 20 mm of filament back
        lines.insert(
            first_new_extrusion,
            b"G1 E-20 F2100"
            if out.state.e_relative[first_new_extrusion]
            else f"G1 E{out.state.e[first_new_extrusion - 1] - 20:.5f} F2100".encode(),
        )
    elif how == "outside":  # a new extrusion ends 100 mm away from its region
        head, e = lines[first_new_extrusion].rsplit(b" E", 1)
        x = out.state.x[first_new_extrusion] + 100.0
        y = out.state.y[first_new_extrusion]
        lines[first_new_extrusion] = f"G1 X{x:.3f} Y{y:.3f}".encode() + b" E" + e
    elif how == "state":  # the feedrate a kept move expects is changed by a new line before it
        last_new = int(np.flatnonzero(new)[-1])
        lines.insert(last_new + 1, b"G1 F1234.5")
    elif how == "layer":  # a layer marker dropped
        marker = b";LAYER_CHANGE" if program.dialect.family != "cura" else b";LAYER:"
        k = max(i for i, ln in enumerate(lines) if ln.startswith(marker))
        lines[k] = b";"
    return b"\n".join(lines)


@pytest.mark.parametrize("read", ["whole", "pieces", "groups", "forked"])
@pytest.mark.parametrize("how", ["kept line", "volume", "retraction", "outside", "state", "layer"])
def test_same_verdict_on_damaged_files(spliced, how, read):
    piece_lines, groups, workers = READS[read]
    program, result, _, _, regions = spliced
    data = _damage(program, result, gcode.parse(result.data, strict=False), how)
    want = check_splice(program, gcode.parse(data, strict=False), result, regions=regions)
    assert want.problems, f"the damage ({how}) went unnoticed"
    assert not any("np." in p for p in want.problems), want.problems  # values as numbers, not reprs
    got = check_output(
        program, data, result, regions=regions, piece_lines=piece_lines, workers=workers, groups=groups
    )
    _same(got, want)


def test_a_wrong_guess_is_read_again(spliced, monkeypatch):
    """A group whose guessed start is not where the group before it ended is read again from there:
    with every guess made on tool 7 (which no layer of these files changes), the verdict is still
    the whole read's."""
    from dataclasses import replace

    from loadpath.splice import piecewise

    program, result, out, check, regions = spliced
    made = []
    start_before = piecewise._start_before

    def on_tool_7(so, i):
        made.append(i)
        return replace(start_before(so, i), tool=7)

    monkeypatch.setattr(piecewise, "_start_before", on_tool_7)
    monkeypatch.setattr(piecewise, "read_piece", _counting(piecewise.read_piece, calls := []))
    got = check_output(program, result.data, result, regions=regions, piece_lines=150, groups=3)
    _same(got, check)
    assert len(made) == 2
    pieces = len(_cuts(program, result.line_map(program.n_lines), out.n_lines, 150))
    # every piece once, two windows, and the groups read again: more than the pieces and windows
    assert len(calls) > pieces + 2


def test_guesses_hold_on_real_files(spliced, monkeypatch):
    """Each group but the first is read once, from its guess: the output's layer before it, read from
    the original's state at its marker, ends where the group before ended."""
    from loadpath.splice import piecewise

    program, result, out, check, regions = spliced
    monkeypatch.setattr(piecewise, "read_piece", _counting(piecewise.read_piece, calls := []))
    _same(check_output(program, result.data, result, regions=regions, piece_lines=150, groups=3), check)
    assert len(calls) == len(_cuts(program, result.line_map(program.n_lines), out.n_lines, 150)) + 2


def _counting(fn, calls):
    def wrapped(*args, **kwargs):
        calls.append(1)
        return fn(*args, **kwargs)

    return wrapped


def test_pieces_hold_the_whole_reads_arrays(spliced):
    """The output read in pieces of 150 lines, each from the state its previous piece ended in: every
    per-line array the check reads is the whole read's, bit for bit (relative E sums included)."""
    from loadpath.gcode.parse import _volumetric_area
    from loadpath.splice.lineview import Carry, read_piece
    from loadpath.splice.piecewise import _line_offsets

    program, result, out, _, _ = spliced
    cuts = _cuts(program, result.line_map(program.n_lines), out.n_lines, 150)
    offsets = [0, *_line_offsets(result.data, cuts[1:]), len(result.data)]
    assert len(cuts) >= 3
    names: list[str] = []
    carry, parts = Carry(), []
    area = _volumetric_area(program.config)
    for a, z in zip(offsets[:-1], offsets[1:], strict=True):
        piece = read_piece(result.data[a:z], carry, names, area)
        parts.append(piece.view)
        carry = piece.carry
    whole = read_lines(result.data)
    for name in ("cmd", "x", "y", "z", "e", "de", "f", "retracted", "tool", "e_relative", "fw_retracted"):
        got = np.concatenate([getattr(v.state, name) for v in parts])
        assert np.array_equal(got, getattr(whole.state, name), equal_nan=name == "f"), name
    assert np.array_equal(np.concatenate([v.kind_of_line for v in parts]), whole.kind_of_line)
    widths = np.concatenate([v.width_of_line for v in parts])
    assert np.array_equal(widths, whole.width_of_line, equal_nan=True)
    feats = np.concatenate([v.feature_of_line for v in parts])
    assert [names[f] if f >= 0 else None for f in feats.tolist()] == [
        whole.features[f] if f >= 0 else None for f in whole.feature_of_line.tolist()
    ]
