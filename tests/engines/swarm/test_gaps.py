"""Gap fill internals against independent references: exact distances and the voids (GEOS)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath.engines.swarm.gaps import _near_distance, segment_distance
from loadpath.engines.swarm.voids import find_voids, ribbons
from shapely.geometry import Point, box


def _random_segments(rng, n, zero=10):
    a = rng.uniform(0.0, 10.0, (n, 2))
    b = a + rng.normal(0.0, 0.5, (n, 2))
    b[:zero] = a[:zero]  # zero-length segments are points
    return a, b


def test_segment_distance_matches_shapely_on_random_segments():
    rng = np.random.default_rng(4)
    a, b = _random_segments(rng, 2000)
    p = rng.uniform(-1.0, 11.0, (2000, 2))
    ref = shapely.distance(shapely.points(p), shapely.linestrings(np.stack([a, b], axis=1)))
    np.testing.assert_allclose(segment_distance(p, a, b), ref, rtol=0, atol=1e-12)


def test_near_distance_is_exact_below_the_reach_less_half_the_longest_segment():
    rng = np.random.default_rng(7)
    a, b = _random_segments(rng, 300)
    p = rng.uniform(0.0, 10.0, (700, 2))
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    ref = shapely.distance(shapely.points(p)[:, None], lines[None, :]).min(axis=1)
    cut = 0.3
    reach = cut + 0.5 * float(np.max(np.hypot(*(b - a).T)))
    got = _near_distance(p, a, b, reach)
    close = ref < cut
    assert 50 < close.sum() < len(p)  # both cases are exercised
    np.testing.assert_allclose(got[close], ref[close], rtol=0, atol=1e-12)
    assert np.all(got[~close] >= cut)


@pytest.mark.parametrize("across", [False, True])
def test_voids_match_the_geos_overlay_of_windows_ribbons_and_region(across):
    # two rows of paths meeting head on behind a hole, in a region of two islands; ``across``
    # mirrors the layer about y = x, so the ends stand side by side along x (Clipper then works
    # on the layer turned by a quarter)
    pitch = 0.4
    region = box(0, 0, 10, 4).difference(Point(5.0, 2.0).buffer(0.7)).union(box(11, 0, 13, 4))
    ys = pitch * (0.5 + np.arange(10))
    left = [
        np.column_stack([np.linspace(0.2, 4.1 + 0.1 * (i % 3), 12), np.full(12, y)]) for i, y in enumerate(ys)
    ]
    right = [
        np.column_stack([np.linspace(5.9 - 0.07 * (i % 4), 9.8, 12), np.full(12, y)])
        for i, y in enumerate(ys)
    ]
    paths = left + right
    paths += [np.column_stack([np.full(9, 12.0), np.linspace(0.3, 3.7, 9)])]
    if across:
        paths = [q[:, ::-1].copy() for q in paths]
        region = shapely.transform(region, lambda xy: xy[:, ::-1])
    counts = np.array([len(q) for q in paths])
    pts = np.concatenate(paths)
    w = np.full(len(pts), pitch)
    starts = np.cumsum(counts) - counts
    last = starts + counts - 1
    seg = np.setdiff1d(np.arange(len(pts)), last)
    ends = np.concatenate([pts[starts], pts[last]])
    radius, min_area = 2.0 * pitch, 0.5 * pitch**2
    got = find_voids(ends, radius, region, ribbons(pts, w, starts, seg), min_area)
    lines = np.array([shapely.LineString(q) for q in paths], dtype=object)
    beads = shapely.union_all(shapely.buffer(lines, 0.5 * pitch, cap_style="flat", join_style="mitre"))
    windows = shapely.union_all(shapely.buffer(shapely.points(ends), radius, quad_segs=8))
    ref = [g for g in shapely.get_parts(windows.intersection(region).difference(beads)) if g.area >= min_area]
    assert len(got) == len(ref) >= 3
    for g in ref:
        match = max(got, key=lambda h: h.intersection(g).area)  # (GEOS keeps zero-width spikes)
        # Clipper works on a 2^-20 mm grid: the outlines agree within a nanometre
        assert shapely.symmetric_difference(g, match).area < 1e-6 * g.length
