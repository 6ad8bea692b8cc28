"""loadpath.metrics: definitions checked on paths whose answers are known by hand."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath import metrics as M
from loadpath.errors import SettingsError
from loadpath.field import AnalyticField, kirsch_tensor
from loadpath.toolpath import Path, Toolpaths
from shapely.geometry import MultiPolygon, Point, box


def _uniform(angle_deg: float, region=None) -> AnalyticField:
    a = np.deg2rad(angle_deg)
    c, s = np.cos(a), np.sin(a)

    def func(p):
        n = len(p)
        return np.tile([c * c, s * s, c * s], (n, 1))

    return AnalyticField(func, region, scale=1.0)


def _line(y, x0=0.0, x1=10.0, pitch=0.4, n=11):
    x = np.linspace(x0, x1, n)
    return Path(np.stack([x, np.full(n, y)], axis=1), np.full(n, pitch))


SPECIMEN = box(0, 0, 150, 36).difference(Point(75, 18).buffer(3, quad_segs=64))


def test_rectilinear_tiles_a_rectangle_at_the_pitch():
    region = box(0, 0, 20, 10)
    tp = M.rectilinear(region, 0.4, 0.0)
    assert len(tp.paths) == 25  # 10 mm / 0.4 mm
    sp = M.spacing(tp, 0.4)
    assert sp.mean == pytest.approx(1.0, abs=1e-9) and sp.variance < 1e-12
    cov = M.coverage(tp, region, flow_width=0.4)
    assert cov.coverage > 0.999 and cov.overlap < 1e-3
    # beads wider than the pitch overlap by the excess: (0.44 - 0.4) / 0.4 = 10 %
    wide = M.coverage(tp, region, flow_width=0.44)
    assert wide.overlap == pytest.approx(0.1, abs=0.01)
    assert M.crossings(tp) == 0


def test_rectilinear_at_any_angle_stays_in_a_region_with_holes_and_islands():
    region = MultiPolygon([box(0, 0, 10, 10).difference(Point(5, 5).buffer(2)), box(20, 0, 30, 5)])
    for ang in (0.0, 33.0, -45.0, 90.0):
        tp = M.rectilinear(region, 0.5, ang)
        assert all(region.buffer(1e-6).contains(Point(q)) for p in tp.paths for q in p.points)
        cov = M.coverage(tp, region, flow_width=0.5)
        assert cov.coverage > 0.98 and cov.overlap < 0.01
        assert M.crossings(tp) == 0
        d = np.array([p.points[-1] - p.points[0] for p in tp.paths])
        a = np.deg2rad(ang)
        assert np.allclose(np.abs(d @ [np.cos(a), np.sin(a)]), np.linalg.norm(d, axis=1))


def test_cross_hatching_alternates_plus_and_minus_45():
    region = box(0, 0, 10, 10)
    for layer, expected in ((0, 45.0), (1, 135.0), (2, 45.0)):
        d = np.diff(M.cross_hatching(region, 0.4, layer).paths[0].points[[0, -1]], axis=0)[0]
        assert np.rad2deg(np.arctan2(d[1], d[0])) % 180.0 == pytest.approx(expected)


@pytest.mark.parametrize(
    "angle,beta", [(0.0, 1.0), (90.0, 0.0), (45.0, np.sqrt(0.5)), (30.0, np.cos(np.pi / 6))]
)
def test_alignment_of_straight_lines_in_a_uniform_field(angle, beta):
    region = box(0, 0, 10, 10)
    res = M.alignment(M.rectilinear(region, 0.5, angle), _uniform(0.0, region), 0.5, region=region)
    assert res.beta == pytest.approx(beta, abs=1e-9)
    assert np.isnan(res.beta_curved) and res.curved_weight == 0.0  # a uniform field never curves
    assert res.dominant_deg == pytest.approx(0.0, abs=1e-6)


def test_alignment_is_mass_weighted():
    # field along x with |s| = 1 for y < 5 and 0.25 above; one path along x below, one along y above
    def func(p):
        m = np.where(p[:, 1] < 5, 1.0, 0.25)
        return np.stack([m, 0 * m, 0 * m], axis=1)

    f = AnalyticField(func, None, scale=1.0)
    along = Path(np.array([[0, 1.0], [10, 1.0]]), np.full(2, 0.5))
    across = Path(np.array([[5, 6.0], [5, 16.0]]), np.full(2, 0.5))
    res = M.alignment([along, across], f, 0.5)
    # 21 points each, weights 1 and 0.25: beta = 1 * 21 / (21 + 0.25 * 21)
    assert res.beta == pytest.approx(1.0 / 1.25, rel=1e-9)


def test_curved_beta_separates_the_annulus_around_the_hole():
    f = AnalyticField(lambda p: kirsch_tensor(p, (75, 18), 3, 1.0), SPECIMEN, scale=3.0)
    aligned = M.alignment(M.rectilinear(SPECIMEN, 0.4, 0.0), f, 0.4, region=SPECIMEN)
    assert aligned.beta > 0.995  # straight lines look almost perfect on the whole specimen ...
    assert aligned.beta_curved < 0.95  # ... but not where the field turns around the hole
    assert 0.0 < aligned.curved_weight < 0.1
    angle, best = M.best_rectilinear(SPECIMEN, f, 0.4, angles_deg=range(0, 180, 15))
    assert best.beta_curved >= aligned.beta_curved - 1e-12


def test_spacing_definitions_on_hand_built_paths():
    paths = [_line(0.0), _line(0.4), _line(1.2)]  # all printed along +x: left is +y
    near = M.spacing(paths, 0.4, "nearest")
    assert sorted(np.unique(np.round(near.values, 9))) == [1.0, 2.0]
    assert near.n == 78 and near.mean == pytest.approx(4 / 3)  # 26 points per 10 mm line
    nxt = M.spacing(paths, 0.4, "next")
    # y = 0 -> 0.4 (1.0), y = 0.4 -> 1.2 (2.0), y = 1.2 has no path on its left
    assert nxt.n == 52 and nxt.mean == pytest.approx(1.5) and nxt.variance == pytest.approx(0.25)
    with pytest.raises(SettingsError, match="spacing definition"):
        M.spacing(paths, 0.4, "average")


def test_spacing_measures_to_segments_not_vertices():
    # the neighbour has only its two end vertices: the distance is still the perpendicular one
    a = _line(0.0)
    b = Path(np.array([[-5.0, 0.5], [15.0, 0.5]]), np.full(2, 0.4))
    assert M.spacing([a, b], 0.4).values[:26] == pytest.approx(np.full(26, 1.25))


def test_variable_width_beads_use_the_local_pitch():
    p = Path(np.array([[0.0, 5.0], [10.0, 5.0]]), np.array([0.8, 0.8]))
    region = box(-5, 0, 15, 10)
    cov = M.coverage([p], region)
    assert cov.coverage * region.area == pytest.approx(10 * 0.8 + np.pi * 0.4**2, rel=1e-2)
    assert cov.flow_width is None


def test_crossings_and_travel():
    a = Path(np.array([[0.0, 0.0], [10.0, 10.0]]), np.full(2, 0.4))
    b = Path(np.array([[0.0, 10.0], [10.0, 0.0]]), np.full(2, 0.4))
    c = Path(np.array([[20.0, 0.0], [30.0, 0.0]]), np.full(2, 0.4))
    assert M.crossings([a, b, c]) == 1
    assert M.crossings([a, c]) == 0
    assert M.travel([a, c]) == pytest.approx(np.hypot(10, 10))


def test_evaluate_and_baselines_bundle_everything():
    region = box(0, 0, 12, 6)
    f = _uniform(0.0, region)
    tp = M.rectilinear(region, 0.5, 0.0)
    m = M.evaluate(tp, region, f, 0.5, flow_width=0.5, time_s=0.1)
    row = m.row()
    assert row["beta"] == pytest.approx(1.0) and row["n_paths"] == 12 and row["time_s"] == 0.1
    assert row["crossings"] == 0 and row["coverage"] > 0.99
    base = M.baselines(region, f, 0.5, flow_width=0.5)
    assert set(base) == {"aligned", "cross+45", "cross-45", "best"}
    assert base["aligned"].alignment.beta == pytest.approx(1.0)
    assert base["cross+45"].alignment.beta == pytest.approx(np.sqrt(0.5), abs=1e-6)


def test_toolpaths_and_sequences_are_both_accepted():
    tp = Toolpaths(paths=(_line(0.0), _line(0.4)))
    assert M.spacing(tp, 0.4).mean == M.spacing(list(tp.paths), 0.4).mean
