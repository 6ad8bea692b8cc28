"""Predictions on meshed parts: material bookkeeping, 2D against 3D, the ceiling bounds straight designs."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath import metrics
from loadpath.loadcase import Body, parse, resolve
from loadpath.stiffness import (
    Deposits,
    StiffnessOptions,
    ceiling,
    from_toolpaths,
    gains,
    predict,
    sample_deposits,
    stiffness_mesh,
)

PLATE = shapely.box(0, 0, 60, 20).difference(shapely.Point(30, 10).buffer(3, quad_segs=32))
CASE = """
version = 1
[[supports]]
name = "clamp"
where = { x_max = 0.01 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { x_min = 59.99 }
force = [500.0, 0.0, 0.0]
"""
LAYERS, H = 4, 0.25


def body(region=PLATE):
    return Body.from_layers("plate", [(k * H, (k + 1) * H, region) for k in range(LAYERS)])


def lines(angles, region=PLATE, pitch=0.45):
    """One layer of straight beads per angle (clipped to the region, as a slicer does)."""
    parts = []
    for k in range(LAYERS):
        tp = metrics.rectilinear(region, pitch, angles[k % len(angles)])
        parts.append(from_toolpaths(tp, (k + 1) * H, H, k))
    return Deposits.concat(parts)


@pytest.fixture(scope="module")
def rb2d():
    (rb,) = resolve(parse(CASE), [body()])
    assert rb.analysis == "2d"
    return rb


@pytest.fixture(scope="module")
def mesh2d(rb2d):
    return stiffness_mesh(rb2d, 0.45)


def test_material_is_conserved_between_beads_and_elements(mesh2d):
    dep = lines([0.0, 90.0])
    f = sample_deposits(mesh2d, dep, 0.1)
    assert f.total_volume + f.lost == pytest.approx(dep.total_volume, rel=1e-12)
    assert f.lost < 1e-3 * dep.total_volume  # only bead edges at the hole's chords stick out
    assert list(f.layers) == [0, 1, 2, 3]
    np.testing.assert_allclose(f.weight.sum(), 1.0)
    # the slicer's lines stop at the outline: the fill is about 1 inside
    assert np.median(f.mean_fill()) == pytest.approx(1.0, abs=0.02)


def test_ceiling_bounds_every_straight_design_and_aligned_beats_cross_hatching(rb2d, mesh2d):
    opts = StiffnessOptions(resolution=0.1)
    designs = {
        name: predict(rb2d, lines(a), opts, mesh2d)
        for name, a in {
            "aligned": [0.0],
            "cross": [45.0, -45.0],
            "0/90": [0.0, 90.0],
            "transverse": [90.0],
        }.items()
    }
    top = ceiling(rb2d, opts, mesh2d)
    for name, p in designs.items():
        assert p.compliance > top.compliance, name
        assert abs(2 * p.strain_energy - p.compliance) < 1e-6 * p.compliance
        assert p.info["residual"] < 1e-8
    assert designs["aligned"].compliance < designs["0/90"].compliance < designs["transverse"].compliance
    assert designs["aligned"].compliance < designs["cross"].compliance
    g = gains(designs["cross"], designs["aligned"], top)
    assert 0 < g["share"] < 1 and g["ceiling_gain"] > g["gain"] > 0
    assert g["gain"] == pytest.approx(designs["cross"].compliance / designs["aligned"].compliance - 1)
    # the ceiling's history never gets worse than its best, which it keeps
    assert top.compliance == min(top.info["history"])
    assert top.mass == pytest.approx(PLATE.area * LAYERS * H * 1e-3 * opts.material.density, rel=1e-3)


def test_missing_material_makes_the_part_softer(rb2d, mesh2d):
    opts = StiffnessOptions(resolution=0.1)
    full = predict(rb2d, lines([0.0]), opts, mesh2d)
    dep = lines([0.0])
    holed = dep.select(~(np.abs(dep.start[:, 1] - 4.0) < 1.0))  # two bead rows removed near y = 4 mm
    gap = predict(rb2d, holed, opts, mesh2d)
    assert gap.compliance > full.compliance
    assert gap.mass < full.mass


@pytest.mark.slow
def test_3d_analysis_of_a_thin_plate_agrees_with_the_2d_ply_stack():
    (rb2,) = resolve(parse(CASE), [body()])
    (rb3,) = resolve(parse(CASE), [body()], analysis="3d")
    dep = lines([0.0, 90.0])
    opts = StiffnessOptions(resolution=0.1)
    p2 = predict(rb2, dep, opts)
    p3 = predict(rb3, dep, opts)
    assert p3.analysis.mesh.dim == 3
    assert p3.volume == pytest.approx(p2.volume, rel=1e-9)
    # 3D adds the through-thickness constraint at the clamp; thin plate: within a few per cent
    assert p3.compliance == pytest.approx(p2.compliance, rel=0.04)
