"""Volume matching of a planned block: excess comes out of the links, not the paths' beads."""

from __future__ import annotations

import numpy as np
import shapely
from loadpath.splice.flow import FlowModel
from loadpath.splice.plan import PlanOptions, plan_block
from loadpath.toolpath import Path

FLOW = FlowModel("rounded", 1.75)
H = 0.2
PITCH = 0.45


def _plan(target=None, **opts):
    # 20 lines 30 mm long, one pitch apart: printed as one zigzag joined by 19 links of one pitch
    paths = [Path(np.array([[0.0, k * PITCH], [30.0, k * PITCH]]), np.full(2, PITCH)) for k in range(20)]
    region = shapely.box(-0.3, -0.3, 30.3, 20 * PITCH)
    options = PlanOptions(nozzle_diameter=0.4, **opts)
    return plan_block(
        paths,
        np.zeros(2),
        H,
        2400.0,
        FLOW,
        options,
        region=region,
        nominal_pitch=PITCH,
        target_filament=target,
    )


def _widths(plan):
    c = plan.chains[0]
    seg = np.hypot(*np.diff(c.points, axis=0).T)
    return c.width[seg > 1.0], c.width[seg <= 1.0], plan.filament


def test_excess_is_taken_from_the_links_first():
    free = _plan(match_volume=False)
    assert free.n_links == 19
    lines0, links0, total0 = _widths(free)
    # a slicer that extruded 0.5 % less: the links give it back, the lines keep their width
    plan = _plan(target=0.995 * total0)
    lines, links, total = _widths(plan)
    assert abs(total - 0.995 * total0) <= 1e-6 * total0
    np.testing.assert_allclose(lines, lines0, rtol=1e-9)
    assert np.all(links < links0) and plan.correction == 1.0
    # more than the links hold: links at the narrowest bead, then every bead scaled
    plan = _plan(target=0.9 * total0)
    lines, links, total = _widths(plan)
    assert abs(total - 0.9 * total0) <= 1e-3 * total0
    assert np.all(lines < lines0) and np.allclose(links, 0.6 * 0.4)
    # too little: every bead widened alike (nothing to take from)
    plan = _plan(target=1.05 * total0)
    lines, links, total = _widths(plan)
    assert abs(total - 1.05 * total0) <= 1e-3 * total0 and np.all(lines > lines0)


def test_a_band_keeps_the_engines_widths():
    free = _plan(match_volume=False)
    plan = _plan(target=1.01 * free.filament, volume_cap=0.02, volume_floor=0.02)
    assert plan.filament == free.filament and plan.correction == 1.0
