"""Corridor fit (issue 17): the deviation and material bounds hold, ends and hairpins stay, fewer vertices."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.splice.corridor import corridor_fit
from loadpath.splice.plan import simplify_mask


def _pieces(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Curved and wobbly lines (an engine's far field), with a cumulative extrusion that speeds up."""
    rng = np.random.default_rng(seed)
    pts, g, sizes = [], [], []
    for _ in range(12):
        n = int(rng.integers(2, 300))
        s = np.cumsum(rng.uniform(0.05, 0.5, n))
        r = rng.uniform(5.0, 80.0)
        y = s**2 / (2 * r) + 0.03 * np.sin(s / rng.uniform(0.3, 3.0)) + rng.normal(0, 0.005, n)
        turn = np.array([[np.cos(r), np.sin(r)], [-np.sin(r), np.cos(r)]])
        pts.append(np.c_[s, y] @ turn + rng.uniform(0, 100, 2))
        dens = 1.0 + 0.3 * (s > s[n // 2])  # a width step half way
        g.append(np.cumsum(np.r_[0.0, np.diff(s) * dens[1:]]))
        sizes.append(n)
    return np.concatenate(pts), np.concatenate(g), np.array(sizes)


def _segment_errors(pts, g, sizes, keep, moved):
    """Per dropped vertex: distance to its printed segment, and |g - g interpolated at its projection|."""
    piece = np.repeat(np.arange(len(sizes)), sizes)
    kv = np.flatnonzero(keep)
    dist, dg = [], []
    for a, z in zip(kv[:-1], kv[1:], strict=True):
        if piece[a] != piece[z]:
            continue
        qa, qb = moved[a], moved[z]
        d = qb - qa
        for j in range(a + 1, z):
            t = np.clip(np.dot(pts[j] - qa, d) / max(np.dot(d, d), 1e-300), 0, 1)
            dist.append(np.hypot(*(pts[j] - qa - t * d)))
            dg.append(abs(g[j] - (g[a] + t * (g[z] - g[a]))))
    return np.array(dist), np.array(dg)


@pytest.mark.parametrize("seed", range(4))
def test_deviation_and_material_bounds_hold(seed):
    pts, g, sizes = _pieces(seed)
    tol, shift = 0.04, 0.2
    keep, moved = corridor_fit(pts, g, sizes, tol, shift)
    dist, dg = _segment_errors(pts, g, sizes, keep, moved)
    assert dist.max() <= tol + 1e-9
    assert dg.max() <= shift + 1e-9
    assert np.hypot(*(moved - pts).T).max() <= tol + 1e-9  # a kept vertex moves at most tol
    assert np.array_equal(moved[~keep], pts[~keep])
    ends = np.cumsum(sizes)
    for v in np.r_[ends - sizes, ends - 1]:  # every piece's ends kept, in place
        assert keep[v] and np.array_equal(moved[v], pts[v])
    assert keep.sum() < 0.5 * len(keep)


def test_fewer_vertices_than_rdp_on_a_curve():
    """On an arc the chord of RDP sags to one side; the moved segments straddle the arc."""
    s = np.arange(0.0, 60.0, 0.1)
    r = 40.0
    pts = np.c_[r * np.sin(s / r), r * (1 - np.cos(s / r))]
    g = s.copy()
    sizes = np.array([len(s)])
    tol = 0.04
    keep, moved = corridor_fit(pts, g, sizes, tol, shift=1.0)
    rdp = simplify_mask(pts, g, sizes, tol, 1.0, 0.05)
    assert keep.sum() <= 0.8 * rdp.sum()
    dist, _ = _segment_errors(pts, g, sizes, keep, moved)
    assert dist.max() <= tol + 1e-9


def test_hairpins_and_link_corners_stay():
    """A zig-zag of long lines joined by one-pitch links: every corner kept where it was."""
    pitch, length = 0.45, 20.0
    x = np.arange(0.0, length + 1e-9, 0.2)
    rows = []
    for k in range(5):
        y = k * pitch + 0.02 * np.sin(x / 2.0)
        line = np.c_[x, y] if k % 2 == 0 else np.c_[x[::-1], y[::-1]]
        rows.append(line)
    pts = np.concatenate(rows)
    g = np.r_[0.0, np.cumsum(np.hypot(*np.diff(pts, axis=0).T))]
    corners = np.cumsum([len(r) for r in rows])[:-1]
    corners = np.r_[corners - 1, corners]  # the last vertex of a line and the first of the next
    keep, moved = corridor_fit(pts, g, np.array([len(pts)]), 0.2 * pitch, shift=0.5 * pitch)
    assert keep[corners].all()
    np.testing.assert_array_equal(moved[corners], pts[corners])
    # the long lines themselves lose almost every vertex
    assert keep.sum() <= len(corners) + 2 + 5 * 6
