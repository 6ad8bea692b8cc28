"""Path ends pulled back so their round bead end does not sit on the bead ahead (:mod:`.caps`)."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath import metrics as M
from loadpath.engines.swarm.caps import settle_ends
from loadpath.toolpath import Path, Toolpaths
from shapely.geometry import box

W = 0.4


def _tp(paths, widths):
    return Toolpaths(
        paths=tuple(Path(points=p, pitch=w) for p, w in zip(paths, widths, strict=True)), stats={}
    )


def _tee(angle_deg: float):
    """A long bead along y = 2 and one running into it at ``angle_deg``, its square end touching it."""
    region = box(0, 0, 12, 8)
    d = np.array([np.cos(np.radians(angle_deg)), -np.sin(np.radians(angle_deg))])  # heading down
    # the square end touches the bead side (y = 2 + W/2) at its lower corner
    n = np.array([-d[1], d[0]])
    corner_drop = 0.5 * W * abs(n[1])
    end = np.array([6.0, 2.0 + 0.5 * W + corner_drop])
    stem = end - d * np.linspace(4.0, 0.0, 9)[:, None]
    base = np.stack([np.linspace(0.2, 11.8, 30), np.full(30, 2.0)], axis=1)
    return region, [base, stem], [np.full(30, W), np.full(9, W)]


@pytest.mark.parametrize(("angle", "left", "ratio"), [(90.0, 0.4, 0.3), (60.0, 0.6, 0.8)])
def test_an_end_on_a_bead_side_gives_up_more_overlap_than_coverage(angle, left, ratio):
    # head-on, most of the cap comes off for little void; obliquely, pulling back opens the void
    # on the far side first, so less comes off (balance 1: area for area)
    region, paths, widths = _tee(angle)
    before = M.coverage(_tp(paths, widths), region)
    p, w, st = settle_ends(paths, widths, region, W, balance=1.0)
    after = M.coverage(_tp(p, w), region)
    assert st["ends_settled"] == 1
    # the long bead is untouched; the stem keeps its free end and its line
    np.testing.assert_array_equal(p[0], paths[0])
    np.testing.assert_array_equal(p[1][0], paths[1][0])
    moved = np.hypot(*(p[1][-1] - paths[1][-1]))
    assert 0.0 < moved <= W + 1e-9
    d = paths[1][-1] - paths[1][-2]
    cross = d[0] * (p[1][-1] - paths[1][-2])[1] - d[1] * (p[1][-1] - paths[1][-2])[0]
    assert abs(cross) < 1e-9
    gained = (before.overlap - after.overlap) * region.area
    lost = (before.coverage - after.coverage) * region.area
    assert before.overlap * region.area > 0.3 * np.pi * (0.5 * W) ** 2 / 2  # the cap is on the bead
    assert after.overlap < left * before.overlap
    assert lost < ratio * gained
    # a heavier weight on the void never pulls back farther
    p2, _, _ = settle_ends(paths, widths, region, W, balance=10.0)
    assert np.hypot(*(p2[1][-1] - paths[1][-1])) <= moved + 1e-12


def test_free_ends_and_ends_at_the_edge_stay():
    region = box(0, 0, 10, 4)
    # two parallel paths a pitch apart, their ends a quarter pitch inside the edge
    paths = [np.array([[0.1, 1.0], [5.0, 1.0], [9.9, 1.0]]), np.array([[0.1, 1.4], [5.0, 1.4], [9.9, 1.4]])]
    widths = [np.full(3, W), np.full(3, W)]
    p, w, st = settle_ends(paths, widths, region, W)
    assert st["ends_settled"] == 0
    for a, b in zip(p, paths, strict=True):
        np.testing.assert_array_equal(a, b)


def test_fixed_paths_keep_their_ends_and_a_short_path_keeps_most_of_its_length():
    region, paths, widths = _tee(90.0)
    p, _, st = settle_ends(paths, widths, region, W, fixed=[False, True])
    assert st["ends_settled"] == 0 and np.array_equal(p[1], paths[1])
    # a stem only half a width long moves at most 0.4 of its length
    short = np.array([paths[1][-1] + [0.0, 0.2], paths[1][-1]])
    p, _, _ = settle_ends([paths[0], short], [widths[0], np.full(2, W)], region, W, balance=1.0)
    assert np.hypot(*(p[1][-1] - p[1][0])) >= 0.6 * 0.2 - 1e-9
