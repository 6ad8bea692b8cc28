"""Path ends carried on to the next bead or the layer's edge (used by both engines)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import shapely
from loadpath.engines.finish.ends import extend_ends
from shapely.geometry import box

PITCH = 0.45
STEP = PITCH / 9.0
REGION = box(0, 0, 10, 10)


def _line(a, b, n=20):
    return np.linspace(a, b, n)


def _seg_distance(p, q):
    """Smallest distance between two polylines (exact)."""
    return float(shapely.LineString(p).distance(shapely.LineString(q)))


def test_an_end_runs_on_to_the_bead_it_faces_and_to_the_edge():
    across = _line((0.5, 5.0), (9.5, 5.0))
    up = _line((5.0, 1.0), (5.0, 3.5))
    w = [np.full(len(across), PITCH), np.full(len(up), PITCH)]
    paths, widths, stats = extend_ends([across, up], w, REGION, PITCH)
    new = paths[1]
    # the top end stops where its bead meets the crossing bead (half its width, plus a quarter of its own)
    stop = 5.0 - (0.5 * PITCH + 0.25 * PITCH) - 0.02 * PITCH
    assert stop - STEP - 1e-9 <= new[-1, 1] <= stop + 1e-9
    # the bottom end runs to the layer's edge, a quarter pitch inside it
    assert 0.25 * PITCH - 1e-9 <= new[0, 1] <= 0.25 * PITCH + STEP + 1e-9
    # the crossing path's ends go to the side edges too; widths carried with the new points
    assert paths[0][0, 0] < 0.5 and paths[0][-1, 0] > 9.5
    assert len(widths[1]) == len(new) and np.all(widths[1] == PITCH)
    assert stats["ends_extended"] == 4
    assert _seg_distance(paths[0], new) >= 0.5 * PITCH


def test_ends_heading_for_each_other_share_the_gap():
    left = _line((0.112, 5.0), (4.0, 5.0))
    right = _line((6.0, 5.0), (9.888, 5.0))
    w = [np.full(20, PITCH), np.full(20, PITCH)]
    paths, _, _ = extend_ends([left, right], w, REGION, PITCH)
    a, b = paths[0][-1, 0], paths[1][0, 0]
    gap = b - a
    assert 0.5 * PITCH <= gap <= 0.5 * PITCH + 0.02 * PITCH + 2 * STEP + 1e-9
    # both moved, by about the same length
    assert abs((a - 4.0) - (6.0 - b)) <= 2 * STEP + 1e-9


def test_an_end_stops_where_the_stress_turns_away():
    class Turning:
        """Stress along y below y = 3, along x above (a jump of the followed stress)."""

        def sample(self, pts):
            d = np.where((pts[:, 1] < 3.0)[:, None], [0.0, 1.0], [1.0, 0.0])
            return SimpleNamespace(direction=d, valid=np.ones(len(pts), dtype=bool))

    up = _line((5.0, 1.0), (5.0, 2.0))
    paths, _, _ = extend_ends([up], [np.full(20, PITCH)], REGION, PITCH, field=Turning())
    assert 3.0 - STEP - 1e-9 <= paths[0][-1, 1] < 3.0
    # without the field it runs on to its reach (3 pitches)
    paths, _, _ = extend_ends([up], [np.full(20, PITCH)], REGION, PITCH)
    assert paths[0][-1, 1] >= 2.0 + 3 * PITCH - STEP - 1e-9


def test_crowded_ends_stay_put_and_nothing_crosses():
    # parallel paths a pitch apart whose ends are staggered: each end faces open space only
    # between its neighbours, which it may enter, but never closer than half a pitch to them
    rng = np.random.default_rng(3)
    paths = []
    for k in range(12):
        y = 2.0 + k * PITCH
        x0, x1 = 2.0 + rng.uniform(0, 2), 6.0 + rng.uniform(0, 2)
        paths.append(_line((x0, y), (x1, y)))
    paths.append(_line((8.6, 1.0), (8.6, 9.0)))  # a wall of a path across their right ends
    w = [np.full(len(p), PITCH) for p in paths]
    out, _, _ = extend_ends(paths, w, REGION, PITCH)
    for i in range(len(out)):
        for j in range(i + 1, len(out)):
            assert _seg_distance(out[i], out[j]) >= 0.5 * PITCH - 1e-9, (i, j)
    for p in out:
        assert REGION.buffer(-0.25 * PITCH + 1e-9).contains(shapely.LineString(p))
