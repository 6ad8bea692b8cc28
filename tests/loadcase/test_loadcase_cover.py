"""cover_slabs: coarser prisms for a 3D mesh whose outlines cover every layer's outline."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
import slicing
from loadpath.loadcase import Body, merge_slabs, parse, resolve
from loadpath.body import cover_slabs
from shapely.geometry import Point, box


def twisted_tower() -> Body:
    """The test tower (``slicing.tower_mesh``) as 120 layer outlines (twisted, tapered plate, 8 mm hole)."""
    return Body.from_layers("tower", slicing.tower_layers())


def _miss(cover: Body, layers: Body) -> float:
    """Largest distance from a layer's outline vertex to the covering slab's outline, mm (0 inside)."""
    worst = 0.0
    for s in layers.slabs:
        c = cover.slab_at(0.5 * (s.z0 + s.z1))
        pts = shapely.points(shapely.get_coordinates(s.outline))
        worst = max(worst, float(np.max(shapely.distance(c.outline, pts))))
        # and no area of the layer outside the cover beyond the snapping
        assert shapely.difference(s.outline, c.outline).area <= s.outline.length * 0.05
    return worst


@pytest.mark.parametrize("tol, grid", [(1.7, None), (1.7, 0.25), (0.8, 0.2)])
def test_a_twisted_tapered_stack_becomes_a_few_prisms_covering_every_layer(tol, grid):
    layers = twisted_tower()
    assert len(merge_slabs(layers).slabs) > 15  # what the mesh had to follow before
    cover = cover_slabs(layers, tol, grid)
    assert 2 <= len(cover.slabs) <= math.ceil(30 / tol)
    assert cover.name == layers.name and cover.z_range == layers.z_range
    for a, b in zip(cover.slabs[:-1], cover.slabs[1:], strict=True):
        assert a.z1 == b.z0
    # every layer lies in its prism: exactly without a grid, within the snapping (a grid step) with one
    assert _miss(cover, layers) <= (1e-9 if grid is None else grid)
    for c in cover.slabs:
        # the hole stays a hole (the stress concentration the field needs) ...
        assert len(c.outline.interiors) == 1
        # ... and the cover is no coarser than the tolerance asks: within about tol of each of its layers
        for s in layers.slabs:
            if c.z0 <= 0.5 * (s.z0 + s.z1) <= c.z1:
                assert shapely.hausdorff_distance(c.outline, s.outline) <= 2.0 * tol + (grid or 0.0)
        if grid:
            xy = shapely.get_coordinates(c.outline) / grid
            assert np.allclose(xy, np.round(xy), atol=1e-6)


def test_a_prismatic_or_stepped_part_keeps_its_slabs():
    plate = box(0, 0, 80, 40).difference(Point(60, 12).buffer(3, quad_segs=16))
    wall = box(0, 0, 10, 40)
    prism = Body.from_layers("p", [(0.2 * i, 0.2 * (i + 1), plate) for i in range(20)])
    stepped = merge_slabs(
        Body.from_layers(
            "s",
            [(0.2 * i, 0.2 * (i + 1), plate) for i in range(20)]
            + [(4 + 0.2 * i, 4 + 0.2 * (i + 1), wall) for i in range(30)],
        )
    )
    for body in (prism, stepped):
        cover = cover_slabs(body, 1.5)
        assert len(cover.slabs) == len(merge_slabs(body).slabs)
        for c, s in zip(cover.slabs, merge_slabs(body).slabs, strict=True):
            assert (c.z0, c.z1) == (s.z0, s.z1)
            assert c.outline.equals(s.outline)
    assert cover_slabs(prism, 0.0) == prism


def test_the_mesh_body_keeps_the_selectors_of_the_part():
    """A load case resolved on the covering stack picks the same ends, in the part's own frame."""
    from loadpath.fea.analysis import covered_body

    case = parse(
        'version = 1\nframe = "part"\n'
        '[[supports]]\nname = "base"\nwhere = { z_max = 0.5 }\nfix = ["x", "y", "z"]\n'
        '[[loads]]\nname = "top"\nwhere = { side = "z_max", within = 0.5 }\nforce = [100.0, 0.0, 0.0]\n'
    )
    (rb,) = resolve(case, [twisted_tower()])
    assert rb.analysis == "3d" and len(rb.layers.slabs) == 120
    on = covered_body(rb, 1.7, 0.25)
    assert len(on.body.slabs) < len(rb.body.slabs)
    assert np.array_equal(on.origin, rb.origin)
    for (_, a), (_, b) in zip(rb.supports + rb.loads, on.supports + on.loads, strict=True):
        # the same end faces, of the covering (larger) outlines
        assert a.measure("3d") <= b.measure("3d") <= 1.3 * a.measure("3d")
