"""Facing path ends joined into one path (:mod:`.joins`)."""

from __future__ import annotations

import numpy as np
from loadpath import metrics as M
from loadpath.engines.swarm.joins import join_ends
from loadpath.toolpath import Path, Toolpaths
from shapely.geometry import box

P = 0.4


def _line(x0, x1, y, n=6):
    return np.stack([np.linspace(x0, x1, n), np.full(n, y)], axis=1)


def _tp(paths, widths):
    ps = tuple(Path(points=p, pitch=w) for p, w in zip(paths, widths, strict=True))
    return Toolpaths(paths=ps, stats={})


def test_two_ends_facing_across_a_small_gap_become_one_path():
    region = box(0, 0, 10, 2)
    # the second path runs toward the first one's end: its points are reversed in the join
    a, b = _line(0.1, 4.8, 1.0), _line(9.9, 5.2, 1.0)
    wa, wb = np.full(6, P), np.linspace(0.9 * P, 1.1 * P, 6)
    p, w, origin, st = join_ends([a, b], [wa, wb], region, P)
    assert st["joins"] == 1 and abs(st["join_mm"] - 0.4) < 1e-9
    assert len(p) == 1 and origin == [0]
    np.testing.assert_array_equal(p[0], np.vstack([a, b[::-1]]))
    np.testing.assert_array_equal(w[0], np.concatenate([wa, wb[::-1]]))
    before = M.coverage(_tp([a, b], [wa, wb]), region)
    after = M.coverage(_tp(p, w), region)
    assert after.overlap < before.overlap and after.coverage >= before.coverage


def test_a_chain_of_facing_ends_becomes_one_path_in_order():
    region = box(0, 0, 10, 2)
    a, b, c = _line(0.1, 3.0, 1.0), _line(6.5, 3.5, 1.0), _line(7.0, 9.9, 1.0)
    p, w, origin, st = join_ends([a, b, c], [np.full(6, P)] * 3, region, P)
    assert st["joins"] == 2 and len(p) == 1
    x = p[0][:, 0]
    assert np.all(np.diff(x) > 0) or np.all(np.diff(x) < 0)  # a straight run, no back-tracking
    assert len(p[0]) == 18


def test_ends_that_do_not_face_or_whose_bridge_is_crowded_stay_apart():
    region = box(0, 0, 10, 3)
    # side by side, both heading +x: not facing
    side = [_line(0.1, 5.0, 1.0), _line(0.1, 5.0, 1.0 + P)]
    p, _, _, st = join_ends(side, [np.full(6, P)] * 2, region, P)
    assert st["joins"] == 0 and len(p) == 2
    # facing, but a third path runs half a pitch beside the bridge
    crowded = [_line(0.1, 4.6, 1.0), _line(9.9, 5.4, 1.0), _line(4.0, 6.0, 1.0 + 0.5 * P)]
    p, _, _, st = join_ends(crowded, [np.full(6, P)] * 3, region, P)
    assert st["joins"] == 0 and len(p) == 3
    # facing, but more than two pitches apart
    far = [_line(0.1, 4.0, 1.0), _line(9.9, 5.0, 1.0)]
    p, _, _, st = join_ends(far, [np.full(6, P)] * 2, region, P)
    assert st["joins"] == 0


def test_joined_paths_never_close_a_loop():
    region = box(0, 0, 10, 10)
    # one path bent into a U whose two ends face each other across a small gap: not joined to itself
    u = np.array([[4.8, 5.0], [2.0, 5.0], [2.0, 7.0], [8.0, 7.0], [8.0, 5.0], [5.2, 5.0]])
    p, _, _, st = join_ends([u], [np.full(6, P)], region, P)
    assert st["joins"] == 0 and len(p) == 1
    # two paths whose ends face each other at both ends: one join only
    top = np.array([[4.8, 5.0], [2.0, 5.0], [2.0, 7.0], [4.8, 7.0]])
    bottom = np.array([[5.2, 7.0], [8.0, 7.0], [8.0, 5.0], [5.2, 5.0]])
    p, _, _, st = join_ends([top, bottom], [np.full(4, P)] * 2, region, P)
    assert st["joins"] == 1 and len(p) == 1 and len(p[0]) == 8


def test_hairpins_join_neighbours_ending_side_by_side_only_when_asked():
    region = box(0, 0, 10, 3)
    # two neighbours a pitch apart ending at x = 5 (starting apart), and a third path across their
    # ends
    pair = [
        _line(0.1, 5.0, 1.0),
        _line(2.0, 5.0, 1.0 + P),
        np.array([[5.0 + 0.55 * P, 0.2], [5.0 + 0.55 * P, 2.8]]),
    ]
    widths = [np.full(6, P), np.full(6, P), np.full(2, P)]
    p, _, _, st = join_ends(pair, widths, region, P)
    assert st["joins"] == 0
    before = M.coverage(_tp(pair, widths), region)
    p, w, origin, st = join_ends(pair, widths, region, P, hairpin=0.5)
    assert st["joins"] == 1 and len(p) == 2 and origin == [0, 2]
    np.testing.assert_array_equal(p[0], np.vstack([pair[0], pair[1][::-1]]))
    # the hairpin covers the notch between the two round ends; nothing crosses, spacing kept
    assert M.coverage(_tp(p, w), region).coverage > before.coverage
    assert M.crossings(_tp(p, w)) == 0 and M.spacing(_tp(p, w), P).min >= 0.5
    # the bridge would come closer than asked to the path across the ends
    p, _, _, st = join_ends(pair, widths, region, P, hairpin=0.9)
    assert st["joins"] == 0
