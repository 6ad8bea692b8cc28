"""The per-layer stress field (StressField contract): interpolation, outside, slices, scale, load entry."""

from __future__ import annotations

import loadpath.loadcase as lc
import numpy as np
import pytest
import shapely
from fea_cases import SIGMA_GROSS, open_hole_body, open_hole_case
from loadpath.fea import FEStressField, analyze, field_for_layer, slice_tets
from loadpath.fea.field import field_from_2d
from loadpath.field import StressField, principal_stresses
from loadpath.loadcase import Slab
from loadpath.mesh import MeshSize, mesh_2d, mesh_3d
from shapely.geometry import Point, Polygon, box


@pytest.fixture(scope="module")
def specimen():
    (rb,) = lc.resolve(open_hole_case(), [open_hole_body(96)])
    return analyze(rb, size=MeshSize(3.0, 0.3, 1.0))


def test_field_is_the_nodal_stress_at_nodes_and_nan_outside(specimen):
    f = specimen.field()
    assert isinstance(f, StressField) and isinstance(f, FEStressField)
    m = specimen.mesh
    np.testing.assert_allclose(f.tensor(m.points), specimen.result.stress, rtol=1e-9, atol=1e-9)
    out = f.tensor(np.array([[75.0, 18.0], [-1.0, 5.0], [151.0, 5.0], [np.nan, 1.0]]))
    assert np.all(np.isnan(out))
    s = f.sample(np.array([[75.0, 18.0], [20.0, 18.0]]))
    assert list(s.inside) == [False, True] and list(s.valid) == [False, True]


def test_quadratic_interpolation_is_exact_for_quadratic_fields():
    m = mesh_2d(box(0, 0, 10, 6).difference(Point(5, 3).buffer(1.5)), 1.0)

    def q(p):
        x, y = p[:, 0], p[:, 1]
        return np.stack([1 + x * y, x * x - 2 * y, 3 * y * y + x], axis=1)

    f = field_from_2d(m, q(m.points), scale=1.0)
    cen = m.points[m.cells[:, :3]]
    w = np.random.default_rng(0).dirichlet([1, 1, 1], size=len(cen))
    pts = np.einsum("mk,mkd->md", w, cen)
    np.testing.assert_allclose(f.tensor(pts), q(pts), atol=1e-9)


def test_far_field_is_uniaxial_and_the_hole_edge_carries_kt(specimen):
    f = specimen.field()
    far = f.sample(np.array([[30.0, 10.0], [120.0, 25.0]]))
    np.testing.assert_allclose(far.sigma, SIGMA_GROSS, rtol=0.01)
    np.testing.assert_allclose(np.abs(far.direction[:, 0]), 1.0, atol=1e-3)
    edge = f.sample(np.array([[75.0, 21.0 + 1e-9]]))
    assert edge.sigma[0] / SIGMA_GROSS == pytest.approx(3.09, rel=0.03)
    # the other principal stress is nearly zero there, so "tensile" and "max_abs" agree and
    # "compressive" picks the small one across
    assert f.with_principal("tensile").sample(np.array([[75.0, 21.01]])).sigma[0] == pytest.approx(
        edge.sigma[0], rel=0.01
    )
    comp = f.with_principal("compressive").sample(np.array([[75.0, 21.01]]))
    assert abs(comp.sigma[0]) < 0.05 * edge.sigma[0] and abs(comp.direction[0, 1]) > 0.99


def test_scale_is_a_percentile_away_from_supports_and_loads():
    case = open_hole_case()
    scales, peaks = [], []
    for h_bc in (1.5, 0.15):  # same mesh at the hole, refined at the supports and loads
        (rb,) = lc.resolve(case, [open_hole_body(64)])
        a = analyze(rb, size=MeshSize(3.0, 0.15, h_bc))
        scales.append(a.scale)
        peaks.append(np.abs(a.result.stress).max())
    assert SIGMA_GROSS < scales[0] < 3.1 * SIGMA_GROSS
    # the peak at the clamp's corners grows as the mesh there is refined; the scale does not
    assert peaks[1] > 1.5 * peaks[0]
    assert scales[1] == pytest.approx(scales[0], rel=0.02)


def test_field_knows_where_the_load_enters(specimen):
    f = specimen.field(1.0)
    assert f.load_entry is not None and f.load_entry.length == pytest.approx(36 + 2 * 0.5, abs=1e-3)
    assert f.load_entry.bounds[0] == pytest.approx(149.5, abs=1e-3)
    assert f.support_lines.bounds[2] == pytest.approx(0.5, abs=1e-3)
    assert f.region.area == pytest.approx(open_hole_body(96).slabs[0].outline.area)
    assert specimen.field(0.3) is specimen.field(1.7)  # one 2D field for every layer
    with pytest.raises(ValueError, match=r"z = 5\.0 mm is outside object 'specimen'"):
        field_for_layer(specimen, 5.0)


def test_slice_of_a_tet_mesh_reproduces_nodal_values_and_covers_the_section():
    slabs = [
        Slab(0.0, 2.0, box(0, 0, 10, 8).difference(Point(5, 4).buffer(1.5))),
        Slab(2.0, 5.0, box(0, 0, 6, 8)),
    ]
    m = mesh_3d(slabs, MeshSize(1.5, 0.5, 1.0))
    vals = np.column_stack([m.points[:, 0] ** 2, m.points[:, 1] * m.points[:, 2], m.points[:, 2]])
    for z in (0.7, 1.9999, 3.3):
        corners, tv = slice_tets(m, vals, z)
        e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        outline = slabs[0].outline if z < 2 else slabs[1].outline
        assert area == pytest.approx(outline.area, rel=1e-4)
        # quadratic section data (corners, then edge midpoints): exact for quadratic nodal fields
        pts = np.concatenate([corners, 0.5 * (corners + corners[:, [1, 2, 0]])], axis=1).reshape(-1, 2)
        expect = np.column_stack([pts[:, 0] ** 2, pts[:, 1] * z, np.full(len(pts), z)])
        np.testing.assert_allclose(tv.reshape(-1, 3), expect, atol=1e-9)


def test_3d_field_of_a_uniform_bar_and_of_each_layer():
    case = lc.parse(
        'version = 1\n[[supports]]\nname = "end"\nwhere = { side = "x_min", within = 0.0 }\nfix = ["x"]\n'
        '[[supports]]\nname = "side"\nwhere = { side = "y_min", within = 0.0 }\nfix = ["y"]\n'
        '[[supports]]\nname = "bottom"\nwhere = { side = "z_min", within = 0.0 }\nfix = ["z"]\n'
        '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 0.0 }\nforce = [90.0, 0.0, 0.0]\n'
    )
    (rb,) = lc.resolve(case, [lc.Body.from_layers("bar", [(0, 3.0, box(0, 0, 30, 10))])], analysis="3d")
    a = analyze(rb, size=MeshSize(3.0, 1.5, 2.0))
    for z in (0.4, 1.5, 2.9):
        f = a.field(z)
        assert f.z == z
        pts = np.random.default_rng(1).uniform([0, 0], [30, 10], size=(200, 2))
        np.testing.assert_allclose(f.tensor(pts), np.broadcast_to([3.0, 0.0, 0.0], (200, 3)), atol=1e-8)
        assert f.load_entry.bounds[0] == pytest.approx(30.0)
    assert a.field(0.4) is not a.field(1.5)


def test_sampling_many_points_at_once_matches_one_by_one(specimen):
    f = specimen.field()
    pts = np.random.default_rng(2).uniform([0, 0], [150, 36], size=(5000, 2))
    big = f.tensor(pts)
    inside = shapely.contains_xy(open_hole_body(96).slabs[0].outline, pts[:, 0], pts[:, 1])
    assert np.array_equal(np.isfinite(big[:, 0]), inside)
    few = np.concatenate([f.tensor(pts[i : i + 7]) for i in range(0, 5000, 7)])
    np.testing.assert_array_equal(big, few)


def test_scale_does_not_follow_a_reentrant_corner_singularity():
    """The L-bracket's inner corner stress grows without bound under refinement; the scale does not."""
    outline = Polygon([(0, 0), (60, 0), (60, 15), (15, 15), (15, 40), (0, 40)]).difference(
        Point(52.5, 7.5).buffer(2.5, quad_segs=12)
    )
    case = lc.parse(
        'version = 1\n[[supports]]\nname = "wall"\nwhere = { side = "y_max", within = 0.5 }\n'
        'fix = ["x", "y", "z"]\n[[loads]]\nname = "pin"\nwhere = { hole_near = [52.5, 7.5], radius = 4.0 }\n'
        "force = [0.0, -200.0, 0.0]\n"
    )
    (rb,) = lc.resolve(case, [lc.Body.from_layers("bracket", [(0, 3, outline)])])
    peaks, scales = [], []
    for h_min in (0.5, 0.06):
        a = analyze(rb, size=MeshSize(2.0, h_min, 2 * h_min))
        s1, s2, _, _ = principal_stresses(a.result.stress)
        peaks.append(float(np.max(np.maximum(np.abs(s1), np.abs(s2)))))
        scales.append(a.scale)
    assert peaks[1] > 2.0 * peaks[0]  # the singularity at (15, 15)
    assert scales[1] == pytest.approx(scales[0], rel=0.02)
    assert scales[0] < 0.5 * peaks[0]
