"""Feature blocks and the line spans the splicer replaces (issue 6: "A block's span is explicit")."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath import gcode
from loadpath.gcode.blocks import BARRIER, EXTRUDE, NEUTRAL, RETRACT, TRAVEL, UNRETRACT, WIPE

CASES = [
    ("prusa", "ohs", "mixed"),
    ("prusa", "two_objects", "mixed"),
    ("cura", "ohs", "mixed"),
    ("cura", "two_objects", "solid"),
]


@pytest.fixture(scope="module", params=CASES, ids=["-".join(c) for c in CASES])
def program(request, sliced):
    return gcode.read(sliced(*request.param))


def test_every_layer_extrusion_is_in_exactly_one_block_core(program):
    m = program.moves
    owner = np.full(len(m), -1)
    for i, b in enumerate(program.blocks):
        rows = slice(b["move_start"], b["move_stop"])
        assert (owner[rows][m["extrude"][rows]] == -1).all()
        owner[rows] = i
    inside = m["extrude"] & (m["layer"] >= 0)
    assert (owner[inside] >= 0).all()
    # the block's feature, object and layer are those of its moves
    for b in program.blocks:
        ext = m[b["move_start"] : b["move_stop"]]
        ext = ext[ext["extrude"]]
        assert (ext["feature"] == b["feature"]).all() and (ext["object"] == b["object"]).all()
        assert (ext["layer"] == b["layer"]).all()
        assert b["e"] == pytest.approx(ext["e"].sum())


def test_spans_nest_and_do_not_overlap(program):
    b = program.blocks
    assert (b["span_start"] <= b["start"]).all() and (b["start"] < b["stop"]).all()
    assert (b["stop"] <= b["span_stop"]).all()
    assert (b["span_stop"][:-1] <= b["span_start"][1:]).all()
    assert (b["exit_start"] <= b["exit_stop"]).all() and (b["stop"] <= b["exit_start"]).all()
    kind = program.kind_of_line
    for row in b:
        core = kind[row["start"] : row["stop"]]
        assert core[-1] == EXTRUDE
        # the opening lines before the first extrusion are neutral (;TYPE:, ;WIDTH:, M204, G1 F)
        first_x = row["start"] + int(np.argmax(core == EXTRUDE))
        assert set(kind[row["start"] : first_x]) <= {NEUTRAL, TRAVEL, UNRETRACT}
        entering = kind[row["span_start"] : row["start"]]
        assert set(entering) <= {TRAVEL, UNRETRACT, NEUTRAL}
        if len(entering):
            assert entering[0] in (TRAVEL, UNRETRACT)  # the span starts with the way in
        leaving = kind[row["stop"] : row["span_stop"]]
        assert set(leaving) <= {WIPE, RETRACT, NEUTRAL}
        if len(leaving):
            assert leaving[-1] in (WIPE, RETRACT)
        ex = kind[row["exit_start"] : row["exit_stop"]]
        assert set(ex) <= {WIPE, RETRACT, NEUTRAL}
        assert BARRIER not in set(kind[row["span_start"] : row["start"]]) | set(leaving)


def test_prusa_spans_start_at_the_lift_and_hold_the_type_marker(sliced):
    program = gcode.read(sliced("prusa", "ohs"))
    infill = [
        program.block(i)
        for i in range(len(program.blocks))
        if program.features[program.blocks[i]["feature"]] == "Internal infill"
    ]
    assert len(infill) == 6
    for b in infill:
        text = [program.line(i) for i in range(b.span_start, b.start + 4)]
        assert text[0].startswith("G1 Z")  # lift
        assert text[1].startswith("G1 X") and "E" not in text[1]  # travel
        assert text[2].startswith("G1 Z")  # lower
        assert text[3].startswith("G1 E")  # unretract
        assert b.span_start < b.type_line < b.stop
        assert program.line(b.type_line) == ";TYPE:Internal infill"
        assert b.role == gcode.Role.SPARSE_INFILL and b.object == "ohs.stl id:0 copy 0"


def test_detached_wipe_of_a_layer_s_last_block_retraces_its_last_path(sliced):
    program = gcode.read(sliced("prusa", "ohs"))
    m = program.moves
    found = 0
    for layer in program.layers[:-1]:
        last = program.block(int(np.flatnonzero(program.blocks["layer"] == layer.index)[-1]))
        if last.exit_start == last.exit_stop:
            continue
        # PrusaSlicer wipes after the next layer's ';LAYER_CHANGE ... G92 E0.0' lines
        assert last.exit_start >= program.layers[layer.index + 1].start
        assert last.span_stop == last.stop
        wipes = m[program.move_rows(last.exit_start, last.exit_stop)]
        wipes = wipes[wipes["wipe"]]
        assert len(wipes) >= 1
        ext = m[last.moves][m[last.moves]["extrude"]]
        a = np.c_[ext["x0"], ext["y0"]][None]
        ab = np.c_[ext["x1"], ext["y1"]][None] - a
        p = np.c_[wipes["x1"], wipes["y1"]][:, None]
        t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0, 1)
        dist = np.hypot(*(a + t[..., None] * ab - p).transpose(2, 0, 1)).min(axis=1)
        assert dist.max() < 0.01  # the wipe runs back over the block's own last lines
        found += 1
    assert found >= 5


def test_cura_block_starts_after_its_mesh_label(sliced):
    program = gcode.read(sliced("cura", "ohs"))
    fills = [
        program.block(i)
        for i in range(len(program.blocks))
        if program.blocks[i]["role"] == gcode.Role.SPARSE_INFILL
    ]
    assert len(fills) == 6
    for b in fills:
        assert program.line(b.type_line) == ";TYPE:FILL"
        assert program.line(b.start - 1).startswith(";MESH:")  # the label stays outside the block
        assert program.kind_of_line[b.start - 1] == BARRIER


def test_replacing_a_span_keeps_everything_else(sliced):
    program = gcode.read(sliced("prusa", "ohs"))
    b = program.block(int(np.flatnonzero(program.blocks["role"] == gcode.Role.SPARSE_INFILL)[0]))
    new = program.replace_lines([(b.span_start, b.span_stop, b";replaced\n")])
    old = program.to_bytes()
    a, z = program.line_starts[b.span_start], program.line_starts[b.span_stop]
    assert new == old[:a] + b";replaced\n" + old[z:]
    with pytest.raises(ValueError, match="overlap"):
        program.replace_lines([(10, 20, b""), (15, 25, b"")])
