"""Inputs the long fuzz run (``scripts/fuzz.py``) found, rebuilt from the fuzzer's own small slices.

Each case mutates one number of a real slice the way the fuzzer does (``_mutate_number``: a
coordinate made ``0``) and runs the real command line under the fuzzer's fork harness (30 s CPU).
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import pytest
from fixtures import load_script, made_once

REPO = Path(__file__).resolve().parents[2]


@functools.cache
def _fuzz():
    return load_script(REPO / "scripts" / "fuzz.py", "loadpath_fuzz")


@pytest.fixture(scope="module")
def small_cura_ohs(slice_cache) -> Path:
    folder = slice_cache / "fuzz-small"
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / "small-cura-ohs.gcode"
    return made_once(out, lambda: _fuzz().small_slices(folder))


def _wall_vertex_to_x0(data: bytes) -> bytes:
    """The third move of layer 0's first inner wall (the hole's, in Cura) with its X made 0."""
    rows = data.split(b"\n")
    wall = rows.index(b";TYPE:WALL-INNER", rows.index(b";LAYER:0"))
    moves = [i for i in range(wall, wall + 40) if rows[i].startswith(b"G1 ") and b" X" in rows[i]]
    i = moves[2]
    rows[i] = re.sub(rb" X[0-9.]+", b" X0", rows[i])
    return b"\n".join(rows)


def test_a_hole_wall_vertex_moved_to_x0_is_refused_quickly_not_solved(small_cura_ohs, tmp_path):
    # the hole's wall now reaches x = 0 in layer 0 only: the clamp (x_min + 10 mm) holds that spike's
    # short pieces, which meet the specimen only along edges; before, the 3D solve of the singular
    # system ran 224 CG iterations and a direct solve (20 s) and ended 'did not converge'
    case = tmp_path / "case.gcode"
    case.write_bytes(_wall_vertex_to_x0(small_cura_ohs.read_bytes()))
    kind, text = _fuzz().classify(case, "run", tmp_path, 30.0)
    assert kind == "refused", (kind, text)
    assert "which meets the rest only at a point or along an edge" in text and "is free to" in text, text
