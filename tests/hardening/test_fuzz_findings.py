"""Inputs the long fuzz run (``scripts/fuzz.py``) found, rebuilt from the fuzzer's own small slices.

Each case mutates one number of a real slice the way the fuzzer does (``_mutate_number``: a
coordinate made ``0`` or cut to half its digits) and runs the real command line under the fuzzer's
fork harness (30 s CPU).
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


def _slice(slice_cache, name: str) -> Path:
    folder = slice_cache / "fuzz-small"
    folder.mkdir(parents=True, exist_ok=True)
    return made_once(folder / name, lambda: _fuzz().small_slices(folder))


@pytest.fixture(scope="module")
def small_cura_ohs(slice_cache) -> Path:
    return _slice(slice_cache, "small-cura-ohs.gcode")


@pytest.fixture(scope="module")
def small_cura_bracket(slice_cache) -> Path:
    return _slice(slice_cache, "small-cura-bracket.gcode")


def _wall_vertex(data: bytes, layer: int, k: int, x: bytes) -> tuple[bytes, int]:
    """Move ``k`` of the first inner wall of ``;LAYER:layer`` with its X made ``x``; the file, the line."""
    rows = data.split(b"\n")
    wall = rows.index(b";TYPE:WALL-INNER", rows.index(b";LAYER:%d" % layer))
    moves = [i for i in range(wall, wall + 40) if rows[i].startswith(b"G1 ") and b" X" in rows[i]]
    i = moves[k]
    rows[i] = re.sub(rb" X[0-9.]+", b" X" + x, rows[i])
    return b"\n".join(rows), i + 1


def _refused_at(path: Path, line: int, tmp_path: Path, pattern: str) -> None:
    kind, text = _fuzz().classify(path, "run", tmp_path, 30.0)
    assert kind == "refused", (kind, text[:400])
    assert re.match(rf"loadpath: line {line} \(.*{pattern}", text), text


def test_a_hole_wall_vertex_moved_to_x0_is_refused_at_its_line(small_cura_ohs, tmp_path):
    # the hole's wall reaches x = 0 in layer 0 only, through a bead CuraEngine's E makes 0.002 mm
    # wide.  Found by the long fuzz run with the third vertex: then the clamp (x_min + 10 mm) held
    # only the spike's short pieces, 224 CG iterations and a direct solve (20 s) ended 'did not
    # converge', and check_rigid learned to refuse pieces that meet the rest along an edge
    # (tests/fea/test_fea_loads.py tests that on its own); the file has no ;WIDTH:, so the 1 % flow
    # floor did not see the 0.37 % bead until it took its feature's median flow width as the bead
    case = tmp_path / "case.gcode"
    data, line = _wall_vertex(small_cura_ohs.read_bytes(), 0, 2, b"0")
    case.write_bytes(data)
    _refused_at(case, line, tmp_path,
                r"0\.37 % of what its bead \(0\.4 x 0\.2 mm: no ;WIDTH: for it, the median flow width")


def test_a_hole_wall_vertex_spike_is_refused_quickly_not_solved_in_3d(small_cura_ohs, tmp_path):
    # the eighth vertex of the same wall made 0 (fuzz run #20, cause 2): a 126 mm spike of layer 0
    # that the clamp holds; the old code meshed the part in 3D and ran out of the 30 s CPU in CG
    case = tmp_path / "case.gcode"
    data, line = _wall_vertex(small_cura_ohs.read_bytes(), 0, 7, b"0")
    case.write_bytes(data)
    _refused_at(case, line, tmp_path, r"0\.37 % of what its bead .* \(at least 25 % on a wall")


@pytest.mark.parametrize(("layer", "x"), [(2, b"0"), (0, b"11")])
def test_a_wall_corner_moved_across_the_bed_is_refused_quickly_not_solved_in_3d(
        small_cura_bracket, tmp_path, layer, x):
    # the bracket's inner-wall corner X117.6 made 0 (layer 2) or cut to X11 (layer 0, half its
    # digits): its two moves, 10.8 and 12.5 mm long, now run 107-130 mm with 9-10 % of their bead and
    # fill a wedge one layer thick; the old code passed the 1 % floor and spent over 60 s of CPU in the
    # 3D FEA (measured 60 s CPU limit reached for both); now refused at the stretched move
    case = tmp_path / "case.gcode"
    data, line = _wall_vertex(small_cura_bracket.read_bytes(), layer, 2, x)
    case.write_bytes(data)
    _refused_at(case, line, tmp_path, r"(9\.1|10) % of what its bead .* \(at least 25 % on a wall")
