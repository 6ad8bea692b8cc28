"""Cut links (``loadpath.engines.cuts``, issue 19): free ends paired through cuts in the paths between.

Hand-built layers with known answers; the effect on real slices is checked in
``tests/pipeline/test_printable.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath import metrics
from loadpath.engines.cuts import cut_paths, free_ends
from loadpath.engines.linking import LinkOptions, hop_groups, link_paths
from loadpath.field import AnalyticField
from loadpath.toolpath import Path
from shapely.geometry import box

W = 0.45
REGION = box(0, 0, 20, 6 * W)
ON = LinkOptions(cut_reach=7.0)  # cuts are off by default


def _layer() -> list[Path]:
    """Six straight paths a pitch apart along a 20 mm strip; the second and the fifth stop inside it
    (x 7..12 and 5..10: squeezed out, as a swarm path is between neighbours that close up), the
    other four run edge to edge.  Each short path's ends lie 2.4 mm from the other's, two paths
    between them and no other end within 1 mm: no link reaches them without crossing."""
    out = []
    for k in range(6):
        y = 0.5 * W + k * W
        x0, x1 = {1: (7.0, 12.0), 4: (5.0, 10.0)}.get(k, (0.2, 19.8))
        out.append(Path(np.array([[x0, y], [0.5 * (x0 + x1), y], [x1, y]]), np.full(3, W)))
    return out


def test_two_squeezed_paths_join_the_zigzag_through_cuts():
    paths = _layer()
    old, st0 = link_paths(paths, REGION, W)
    new, st = link_paths(paths, REGION, W, ON)
    assert st0["cuts"] == 0 and len(old) == 3  # the zig-zag and the two squeezed paths alone
    assert st["cuts"] == 4 and len(new) < len(old)  # both pairs of ends, two paths cut each
    assert hop_groups(new, 1.0) < hop_groups(old, 1.0) == 3
    assert metrics.crossings(new) == 0
    assert all(REGION.buffer(1e-3).covers(shapely.LineString(r.points)) for r in new)
    # the plastic path: each cut takes a pitch out of a path, the links put back more than that
    cut_out = st["cuts"] * W
    assert sum(r.length for r in new) >= sum(p.length for p in paths) - cut_out
    assert metrics.coverage(new, REGION).coverage >= metrics.coverage(old, REGION).coverage - 0.005


def test_ends_a_free_travel_apart_are_left_alone():
    """Two free ends less than ``hop`` apart cost no retraction: no cut is made for them."""
    paths = _layer()
    runs, _ = link_paths(paths, REGION, W, LinkOptions(cut_reach=0))
    assert cut_paths(paths, runs, W, reach=7.0, hop=1.0)[1] == 4
    assert cut_paths(paths, runs, W, reach=7.0, hop=3.0)[1] == 0  # every end has a partner within 3 mm


def test_cuts_only_where_the_stress_is_low():
    """A field that carries 10x more in the strip's right half than in its left: at 10 % of the
    layer's 90th percentile only the cuts for the left pair of ends (x 5..7) are made."""
    paths = _layer()
    runs, _ = link_paths(paths, REGION, W, LinkOptions(cut_reach=0))

    def tension(p):
        sxx = np.where(p[:, 0] < 8.5, 1.0, 10.0)
        return np.column_stack([sxx, np.zeros(len(p)), np.zeros(len(p))])

    field = AnalyticField(tension, REGION, scale=10.0)
    cut, n, _ = cut_paths(paths, runs, W, reach=7.0, hop=1.0, field=field, stress_share=0.1)
    assert n == 2
    gaps = [e for e in free_ends(cut) if 0.3 < e[0] < 19.7 and not np.any(np.isclose(e[0], [5, 7, 10, 12]))]
    assert gaps and all(e[0] < 8.5 for e in gaps)
    assert cut_paths(paths, runs, W, reach=7.0, hop=1.0, field=field, stress_share=1.0)[1] == 4


@pytest.mark.parametrize("reach", [0.0, 2.0])
def test_no_cut_beyond_reach(reach):
    paths = _layer()
    runs, st = link_paths(paths, REGION, W, LinkOptions(cut_reach=reach))
    assert st["cuts"] == 0 and len(runs) == 3
