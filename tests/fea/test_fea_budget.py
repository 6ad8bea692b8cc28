"""The default 3D mesh keeps within its element budget; an explicit size is honoured as given."""

from __future__ import annotations

import numpy as np
import pytest
from fea_cases import TOWER_CASE, twisted_tower
from loadpath.fea import build_mesh
from loadpath.loadcase import parse, resolve
from loadpath.mesh import DEFAULT_MAX_TETS, MeshSize


@pytest.fixture(scope="module")
def tower():
    (rb,) = resolve(parse(TOWER_CASE, "tower.toml"), [twisted_tower()])
    assert rb.analysis == "3d" and len(rb.body.slabs) > 15
    return rb


def _layer_volume(rb) -> float:
    return sum(s.outline.area * s.thickness for s in rb.layers.slabs)


def test_default_3d_mesh_of_a_drifting_part_stays_within_the_budget(tower):
    mesh = build_mesh(tower, pitch=0.45)
    st = mesh.stats
    assert mesh.cell_type == "tet10"
    assert len(mesh.cells) <= DEFAULT_MAX_TETS == st["max_cells"]
    assert st["attempts"] > 1  # the pitch-derived size alone would have been over the budget
    # and not needlessly coarse: at least a third of the budget (sizes grow by the cube root of the excess)
    assert len(mesh.cells) >= DEFAULT_MAX_TETS / 3
    # a handful of prisms instead of one per distinct layer, covering every layer's outline
    assert st["slabs"] <= 10 < len(tower.body.slabs)
    vol = float(np.sum(np.abs(mesh.measures)))
    assert _layer_volume(tower) * 0.99 <= vol <= _layer_volume(tower) * 1.25
    lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
    assert hi[2] - lo[2] == pytest.approx(24.0)


def test_a_smaller_budget_coarsens_and_an_explicit_size_is_kept(tower):
    size = MeshSize(4.0, 1.5, 3.0)
    fine = build_mesh(tower, size=size)
    assert fine.stats["h"] == size.h and fine.stats["h_min"] == size.h_min
    assert fine.stats["attempts"] == 1 and fine.stats["max_cells"] is None
    budget = len(fine.cells) // 3
    coarse = build_mesh(tower, pitch=0.45, max_cells=budget)
    assert budget / 4 <= len(coarse.cells) <= budget
    assert coarse.stats["h"] > size.h
