"""The 3D mesh of a real PrusaSlicer print whose outline changes every layer, with selectors across it.

The twisted tower (``tests/slicing.py``) sliced with the shipped example's settings and the benchmark's
load case (clamped within 10 mm of x_min, pulled within 10 mm of x_max): the selector boxes' edges
cross the drifting, slanted outlines. Their crossings snapped to the mesh grid once fell outside the
union of the outlines, and gmsh returned no triangles (``loadpath run`` failed on this part).
"""

from __future__ import annotations

import numpy as np
import pytest
from cases import GRIP_PULL
from loadpath import gcode, geometry
from loadpath.fea import build_mesh
from loadpath.fea.analysis import covered_body
from loadpath.loadcase import parse, resolve
from loadpath.mesh import DEFAULT_MAX_TETS


@pytest.mark.slow  # about 7 s: slicing (cached per session), layer geometry, four budget attempts
def test_sliced_tower_with_side_selectors_gets_its_3d_mesh(sliced):
    path = sliced("prusa", "tower", "example")
    geo = geometry.layer_geometry(gcode.read(path), check=False)
    (rb,) = resolve(parse(GRIP_PULL, "case.toml"), geo.bodies())
    assert rb.analysis == "3d" and len(rb.layers.slabs) >= 100
    mesh = build_mesh(rb, pitch=0.45)
    st = mesh.stats
    assert mesh.cell_type == "tet10" and np.all(mesh.measures > 0)
    assert DEFAULT_MAX_TETS / 3 <= len(mesh.cells) <= DEFAULT_MAX_TETS
    vol = float(mesh.measures.sum())
    # exactly the covering prisms it was made from (up to the snapping grid's bends) ...
    cover = covered_body(rb, st["cover_tol"], st["grid"]).body
    assert abs(vol / sum(s.outline.area * s.thickness for s in cover.slabs) - 1.0) < 0.01
    # ... which hold every layer as sliced, a little more where the twist drifts within a prism
    part = sum(s.outline.area * s.thickness for s in rb.layers.slabs)
    assert part <= vol <= 1.15 * part
    lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
    assert abs(hi[2] - lo[2] - 24.0) < 1e-6
