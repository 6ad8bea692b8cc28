"""The finishing widths' compiled searches against brute force: every ray hit, every centring pair.

:func:`loadpath.engines.finish.widths.local_pitch` promises the first other path crossed by each
normal within ``cap`` pitches, and :func:`~loadpath.engines.finish.widths.centre_points` that no
kept move ends closer than ``min_gap`` to another path.  Both search a cell grid; the references
here test every segment of the layer, in plain numpy.
"""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.engines.finish import kernel_widths as kw
from loadpath.engines.finish import widths as W
from shapely.geometry import box

PITCH = 0.4
CAP = 1.5
REACH = CAP * PITCH


def _layer_arrays(paths):
    pts, counts, pid, seg, tan = W._layer(paths)
    return pts, counts, pid, seg, tan


def _brute_hits(pts, tan, pid, seg, reach):
    """Nearest crossing of every point's normal line with every segment of another path (numpy)."""
    a, b = pts[seg], pts[seg + 1]
    e = b - a  # (s, 2)
    n = np.stack([-tan[:, 1], tan[:, 0]], axis=1)  # (m, 2)
    w = a[None, :, :] - pts[:, None, :]  # (m, s, 2)
    # p + v n = a + s e:  [n, -e] (v, s) = w
    det = -n[:, None, 0] * e[None, :, 1] + e[None, :, 0] * n[:, None, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        v = (-w[..., 0] * e[None, :, 1] + e[None, :, 0] * w[..., 1]) / det
        s = (n[:, None, 0] * w[..., 1] - n[:, None, 1] * w[..., 0]) / det
    # a normal through a vertex meets both segments there at s = 1 and s = 0, which rounding can
    # push just outside [0, 1] here (the kernel's sign test counts a vertex on the line as a hit)
    slack = 1e-9
    ok = (det != 0) & (s >= -slack) & (s <= 1 + slack) & (pid[:, None] != pid[seg][None, :])
    left = np.min(np.where(ok & (v > 0) & (v <= reach), v, np.inf), axis=1)
    right = np.min(np.where(ok & (v < 0) & (-v <= reach), -v, np.inf), axis=1)
    return left, right


def _random_layer(rng, n_paths=40, size=8.0, long_every=0):
    """Random wandering polylines (steps 0.05-0.6 mm; every ``long_every``-th step 2-4 mm long)."""
    paths = []
    for _ in range(n_paths):
        m = int(rng.integers(2, 60))
        step = rng.uniform(0.05, 0.6, m - 1)
        if long_every:
            step[::long_every] = rng.uniform(2.0, 4.0, len(step[::long_every]))
        turn = np.cumsum(rng.normal(0.0, 0.3, m - 1)) + rng.uniform(0, 2 * np.pi)
        d = np.stack([np.cos(turn), np.sin(turn)], axis=1) * step[:, None]
        start = rng.uniform(0, size, 2)
        paths.append(np.vstack([start, start + np.cumsum(d, axis=0)]))
    return paths


def _structured_layers():
    """Layers whose crossings sit on cell edges, at vertices, or across long segments."""
    x = np.linspace(0.0, 6.0, 25)  # vertices every 0.25 mm: normals pass exactly through neighbours' vertices
    parallel = [np.column_stack([x, np.full_like(x, y)]) for y in PITCH * np.arange(8)]
    uneven = [np.column_stack([x, np.full_like(x, y)]) for y in (0.0, 0.23, 0.9, 1.05, 1.7, 2.5)]
    long_lines = [np.array([[0.0, y], [3.0, y + 0.1], [9.0, y]]) for y in (0.0, 0.35, 0.8, 1.3)]
    long_lines.append(np.column_stack([np.linspace(1, 8, 30), np.full(30, 0.6)]))
    t = np.linspace(0, 2 * np.pi, 90)[:-1]
    rings = [np.column_stack([r * np.cos(t), r * np.sin(t)]) for r in (1.0, 1.45, 1.8, 2.3)]
    crossing = [np.array([[0.0, 0.0], [4.0, 4.0]]), np.array([[0.0, 4.0], [4.0, 0.0]])]
    crossing.append(np.array([[2.0, 0.5]]))  # a lone point
    return {"parallel": parallel, "uneven": uneven, "long": long_lines, "rings": rings, "crossing": crossing}


def _kernel_hits(paths, cell, reach=REACH, whole_mm=False):
    """The kernel's hits and the brute-force ones; ``whole_mm``: the grid's origin on whole mm."""
    pts, counts, pid, seg, tan = _layer_arrays(paths)
    origin, cell, nx, ny = W._frame(pts, reach, cell, len(seg))
    if whole_mm:
        origin = np.floor(pts.min(axis=0) - reach - 1.0)
        nx, ny = (np.ceil((pts.max(axis=0) + reach + 1.0 - origin) / cell).astype(int) + 1).tolist()
    start, items = kw.cell_lists(pts, seg, seg[:0], origin, cell, nx, ny)
    rows = np.arange(len(pts))
    left, right = kw.normal_hits(pts, tan, pid, rows, seg, origin, cell, nx, ny, start, items, reach)
    return (left, right), _brute_hits(pts, tan, pid, seg, reach)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("cell", [0.05, 0.2, 1.0])
def test_normal_hits_are_every_first_crossing_on_random_layers(seed, cell):
    rng = np.random.default_rng(seed)
    paths = _random_layer(rng, long_every=7 if seed % 2 else 0)
    (left, right), (bl, br) = _kernel_hits(paths, cell)
    for got, ref in ((left, bl), (right, br)):
        assert np.array_equal(np.isfinite(got), np.isfinite(ref))
        fin = np.isfinite(ref)
        assert fin.sum() > 100  # the layer is dense enough for the test to mean something
        np.testing.assert_allclose(got[fin], ref[fin], rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", list(_structured_layers()))
def test_normal_hits_are_every_first_crossing_on_structured_layers(name):
    paths = _structured_layers()[name]
    # with the grid's origin on whole millimetres, cells of 0.25 mm put the vertices every
    # 0.25 mm on cell edges, cells of 0.2 mm the lines every pitch (up to rounding)
    for cell, whole_mm in ((0.25, True), (0.2, True), (0.5 * PITCH, False)):
        (left, right), (bl, br) = _kernel_hits(paths, cell, whole_mm=whole_mm)
        for got, ref in ((left, bl), (right, br)):
            assert np.array_equal(np.isfinite(got), np.isfinite(ref)), name
            fin = np.isfinite(ref)
            np.testing.assert_allclose(got[fin], ref[fin], rtol=0, atol=1e-9)


def test_local_pitch_finds_the_neighbour_behind_many_nearer_pieces():
    # a finely sampled path that curls next to the point puts dozens of its own pieces nearer than
    # the neighbour straight across: the exact search still finds the neighbour
    rng = np.random.default_rng(3)
    paths = _random_layer(rng, n_paths=60, size=6.0)
    t = np.linspace(0, 12 * np.pi, 400)
    curl = np.column_stack([3 + 0.02 * t * np.cos(t), 3 + 0.02 * t * np.sin(t)])
    paths.append(curl)
    region = box(-100, -100, 100, 100)  # edges far away: no edge rule
    _, left, right = W.local_pitch(paths, region, PITCH, cap=CAP, sides=True)
    pts, _, pid, seg, tan = _layer_arrays(paths)
    bl, br = _brute_hits(pts, tan, pid, seg, REACH)
    for got, ref in ((np.concatenate(left), bl), (np.concatenate(right), br)):
        np.testing.assert_allclose(got, np.minimum(ref, REACH), rtol=0, atol=1e-9)


def test_local_pitch_at_ends_beside_neighbours_that_end_there_too():
    # slanted parallel lines across a 3 mm strip, their vertices on common vertical lines (as level
    # sets contoured on one grid): at every end the normal, tilted by the slant, passes just beyond
    # the neighbour's end on one side.  Without the ends' correction that side found nothing or the
    # line after, and the ends got 1.4-2.5x the spacing.
    slope, gap = 0.15, 0.4
    xs = np.r_[0.1, np.arange(0.4, 2.8, 0.4), 2.9]
    lines = [np.column_stack([xs, 1.0 + i * gap + slope * xs]) for i in range(12)]
    spacing = gap / np.hypot(1.0, slope)
    cap = 2.5
    w, left, right = W.local_pitch(lines, box(0, 0, 3, 10), PITCH, cap=cap, sides=True, ends=True)
    inner = np.concatenate(w[1:-1])
    np.testing.assert_allclose(inner, spacing, rtol=0.02)
    # the outermost lines keep the edge rule on their open side: twice the way to the edge along the
    # normal, at most the cap (the bottom line is 1 mm above the strip's bottom edge)
    assert np.all(right[0][1:-1] > 1.5 * spacing)
    # the raw hits: without the correction the ends are too wide
    pts, _, pid, seg, tan = _layer_arrays(lines)
    bl, br = _brute_hits(pts, tan, pid, seg, cap * PITCH)
    ends = np.r_[0, np.cumsum([len(q) for q in lines])[:-1]]
    raw = np.minimum(np.minimum(bl, cap * PITCH) + np.minimum(br, cap * PITCH), 2 * cap * PITCH) / 2
    assert np.max(raw[ends[1:-1]]) > 1.3 * spacing


def test_local_pitch_without_a_neighbour_reaches_the_edge():
    # one path 0.1 mm from the bottom edge of its region, alone: the right side gets twice the way
    # to the edge, the left side (nothing within reach) the cap
    line = np.column_stack([np.linspace(1, 5, 11), np.full(11, 0.1)])
    w, left, right = W.local_pitch([line], box(0, 0, 6, 3), PITCH, cap=CAP, sides=True)
    assert np.allclose(right[0], 0.2) and np.allclose(left[0], REACH)
    assert np.allclose(w[0], 0.5 * (0.2 + REACH))


# ------------------------------------------------------------------------------------ centring


def _brute_settle(pts, nrm, move, seg, pid, min_gap, rounds):
    """The centring rounds with every (point, segment of another path) pair checked each round."""
    move = move.copy()
    a_i, b_i = seg, seg + 1
    other = pid[:, None] != pid[seg][None, :]
    for _ in range(rounds):
        if not np.any(move != 0.0):
            return move
        q = pts + move[:, None] * nrm
        a, b = q[a_i], q[b_i]
        ab = b - a
        ll = np.sum(ab * ab, axis=1)
        t = np.sum((q[:, None, :] - a[None]) * ab[None], axis=2) / np.where(ll > 0, ll, 1.0)[None]
        t = np.clip(np.where(ll > 0, t, 0.0), 0.0, 1.0)
        d = np.hypot(*np.moveaxis(q[:, None, :] - (a[None] + t[..., None] * ab[None]), -1, 0))
        moved = (move[:, None] != 0) | (move[a_i] != 0)[None] | (move[b_i] != 0)[None]
        close = other & moved & (d < min_gap)
        v, k = np.nonzero(close)
        back = np.unique(np.concatenate([v, a_i[k], b_i[k]]))
        back = back[move[back] != 0.0]
        if not len(back):
            return move
        move[back] = 0.0
    return np.zeros_like(move)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("rounds", [1, 2, 20])
def test_centring_rounds_equal_checking_every_pair(seed, rounds):
    rng = np.random.default_rng(100 + seed)
    paths = _random_layer(rng, n_paths=30, size=5.0) + [np.array([[2.5, 2.5]])]  # and a lone point
    pts, counts, pid, seg, tan = _layer_arrays(paths)
    nrm = np.stack([-tan[:, 1], tan[:, 0]], axis=1)
    move = rng.uniform(-0.15, 0.15, len(pts)) * (rng.random(len(pts)) < 0.6)
    min_gap = 0.53 * PITCH
    radius = min_gap + float(np.max(np.abs(move)))
    lone = np.cumsum(counts)[counts == 1] - 1
    origin, cell, nx, ny = W._frame(pts, radius, radius, len(seg) + len(lone))
    start, items = kw.cell_lists(pts, seg, lone, origin, cell, nx, ny)
    grid = (origin, cell, nx, ny, start, items)
    got, used = kw.settle_moves(pts, nrm, move, seg, lone, pid, min_gap, rounds, *grid)
    ref = _brute_settle(pts, nrm, move, seg, pid, min_gap, rounds)
    assert np.array_equal(got, ref)
    kept, proposed = np.count_nonzero(got), np.count_nonzero(move)
    if rounds == 1:
        assert used == rounds + 1 and kept == 0  # one round is not enough: every move undone
    if rounds == 20:
        assert 1 < used <= rounds and 0 < kept < proposed  # settled after several rounds
