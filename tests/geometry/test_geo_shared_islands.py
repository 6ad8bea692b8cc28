"""Islands where several infill blocks share the domain: real Bambu-family output and constructed pieces.

OrcaSlicer and Bambu Studio print a one-bead ring of internal solid infill along the walls around
sparse infill, and print one sparse fill in several pieces.  The region of every block must be the
part of the domain it fills (``tests/data/published/README.md`` for the file).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from loadpath import gcode, geometry
from loadpath.geometry.regions import BlockLines, check_tolerance, footprints, nearest_split
from loadpath.pipeline.units import select_units, unreliable_blocks
from shapely import box

PUBLISHED = Path(__file__).resolve().parents[1] / "data" / "published"
ORCA_P1S = PUBLISHED / "orcaslicer-2.3.1-bambu-p1s-cube20.gcode"
RING_LAYER = 94  # 0-based: ';Z_HEIGHT: 19' (layer 95 of 100), sparse infill inside a ring of solid infill


@pytest.fixture(scope="module")
def orca_p1s():
    program = gcode.read(ORCA_P1S)
    return program, geometry.layer_geometry(program, check=True)  # raised before the fix


def test_ring_of_solid_infill_around_sparse_infill(orca_p1s):
    program, geo = orca_p1s
    (obj,) = geo.objects
    (layer,) = [lg for lg in obj.layers if lg.layer_index == RING_LAYER]
    (island,) = layer.islands
    features = [b.feature for b in island.blocks]
    assert features == ["Sparse infill", "Internal solid infill", "Sparse infill"]
    for b in island.blocks:
        assert not b.region.is_empty and b.outside <= check_tolerance(b.flow_width), (b.feature, b.outside)
    ring = island.blocks[1]
    # one loop of beads: a solid block (pitch = flow width), its region the band its beads cover
    assert ring.kind == "solid"
    assert ring.pitch == pytest.approx(ring.flow_width)
    assert ring.region.area == pytest.approx(ring.length * ring.flow_width, rel=0.1)
    # the sparse pieces hold the inside of the ring between them; the regions tile the domain
    assert [b.kind for b in island.blocks] == ["sparse", "solid", "sparse"]
    assert sum(b.region.area for b in island.blocks) == pytest.approx(island.domain.area, rel=0.01)
    union = shapely.union_all([b.region for b in island.blocks])
    assert union.area == pytest.approx(island.domain.area, rel=0.01)
    inside = shapely.Polygon(ring.region.interiors[0])
    sparse = shapely.union_all([island.blocks[0].region, island.blocks[2].region])
    assert shapely.symmetric_difference(sparse, inside).area < 0.02 * inside.area


def test_every_block_of_the_file_is_reliable(orca_p1s):
    """A ``replace = solid, sparse`` run keeps no block of this file for leaving its region."""
    _, geo = orca_p1s
    assert unreliable_blocks(geo) == {}
    units = select_units(geo, [geo.objects[0].name], ("solid", "sparse"))
    ring_units = [u for u in units if u.layer == RING_LAYER]
    assert sorted(u.kind for u in ring_units) == ["solid", "sparse"]
    assert sum(len(u.blocks) for u in ring_units) == 3
    # every layer between the solid layers has its sparse infill replaced over the whole domain
    layers = {u.layer for u in units}
    assert layers == set(range(1, 99)) - {95}  # layer 96 (index 95) is a bridge: always kept


def test_crosshatch_sparse_pitch_is_its_line_spacing(orca_p1s):
    """OrcaSlicer's crosshatch (15 %, 0.45 mm) prints staircases of short steps: the spacing of
    steps that do not run alongside each other (0.1-1.2 mm) is no line spacing.  A pitch finer than
    the block's plastic per area (area / length) would lay far more plastic than the slicer."""
    _, geo = orca_p1s
    sparse = [b for lg in geo.objects[0].layers for b in lg.blocks if b.kind == "sparse" and b.length > 100]
    assert len(sparse) > 80
    ratio = np.array([b.pitch / (b.region.area / b.length) for b in sparse])
    assert ratio.min() > 0.7, ratio.min()


def _zigzag(x0, x1, y0, y1, pitch):
    """Sparse lines parallel to y, ``pitch`` apart, joined at their ends (a rectilinear piece)."""
    xs = np.arange(x0, x1 + 1e-9, pitch)
    ya = np.where(np.arange(len(xs)) % 2 == 0, y0, y1)
    yb = np.where(np.arange(len(xs)) % 2 == 0, y1, y0)
    px = np.column_stack([xs, xs]).ravel()
    py = np.column_stack([ya, yb]).ravel()
    return BlockLines(px[:-1], py[:-1], px[1:], py[1:], 0.4, pitch)


def _joined(a, b):
    return BlockLines(*(np.concatenate([getattr(a, k), getattr(b, k)]) for k in ("x0", "y0", "x1", "y1")),
                      a.flow_width, a.pitch)


def test_a_small_sparse_piece_in_a_corner_keeps_its_area():
    """One sparse fill printed in two pieces: a 5 x 7 mm corner piece and the rest (Bambu Studio A1 hook,
    layer 39).  Closing the large piece over its 5 mm pitch, walls included, filled the corner."""
    domain = box(0, 0, 30, 20)
    # all but the corner, and the corner piece x > 25, y < 7
    big = _joined(_zigzag(0.2, 24.8, 0.2, 19.8, 3.0), _zigzag(25.5, 29.8, 7.5, 19.8, 3.0))
    small = _zigzag(25.5, 29.8, 0.2, 6.8, 3.0)
    prints = footprints([big, small], domain)
    corner = box(25, 0, 30, 7)
    assert prints[1].intersection(corner).area > 0.8 * corner.area
    assert prints[0].intersection(corner).area < 0.2 * corner.area
    assert prints[0].area + prints[1].area == pytest.approx(domain.area, rel=1e-3)


def test_nearest_split_follows_the_lines():
    area = box(0, 0, 10, 10)
    left = BlockLines(np.array([1.0]), np.array([0.0]), np.array([1.0]), np.array([10.0]), 0.4, 2.0)
    right = BlockLines(np.array([7.0]), np.array([0.0]), np.array([7.0]), np.array([10.0]), 0.4, 2.0)
    a, b = nearest_split(area, [left, right])
    # the boundary is half-way between the lines, x = 4
    assert a.area == pytest.approx(40.0, rel=0.02) and b.area == pytest.approx(60.0, rel=0.02)
    assert a.bounds[2] == pytest.approx(4.0, abs=0.05)
