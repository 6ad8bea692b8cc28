"""A kept prediction serves beads that lay the same material (loadpath.stiffness.near, change's near keys).

A re-export at other speeds moves a few of PrusaSlicer's beads by hundredths of a millimetre (the
shipped example: 4 of 7657 by up to 0.06 mm), and a second slice of a gyroid part writes a third of
its layers' perimeters and sparse lines in another order, a loop's seam elsewhere; the exact key then
misses.  The near match must take those and refuse beads that moved further, were added or
removed, changed their cross-section or their direction.
"""

from __future__ import annotations

import numpy as np
from loadpath.stiffness.change import near_key
from loadpath.stiffness.deposits import Deposits
from loadpath.stiffness.near import NEAR_MM, NEAR_VOLUME, Beads, match
from loadpath.stiffness.predict import StiffnessOptions


def _deposits(n: int = 50, shift: float = 0.0, scale: float = 1.0, at: int = 7, side: float = 0.0) -> Deposits:
    """``n`` beads 0.7 mm long in a row on two layers (``side`` mm off the x axis); bead ``at``'s end
    moved by ``shift`` along it and its volume per length scaled by ``scale``."""
    x = np.arange(n) * 0.7
    start = np.column_stack([x, np.full(n, side)])
    end = np.column_stack([x + 0.7, np.full(n, side)])
    end[at, 0] += shift
    area = np.full(n, 0.08)
    area[at] *= scale
    volume = area * np.hypot(*(end - start).T)
    layer = (np.arange(n) >= n // 2).astype(np.int64)
    return Deposits(start, end, 0.2 * layer, np.full(n, 0.2), volume, layer, np.ones(n, dtype=np.int64))


def _loop(start_at: int, n: int = 40, reverse: bool = False) -> Deposits:
    """A closed square loop of ``n`` beads, 10 mm a side, printed from its vertex ``start_at``."""
    t = np.linspace(0.0, 4.0, n + 1)
    side, f = np.minimum(np.floor(t), 3).astype(int), t - np.minimum(np.floor(t), 3)
    corners = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], dtype=float)
    pts = corners[side] + f[:, None] * (corners[side + 1] - corners[side])
    ring = np.roll(pts[:-1], -start_at, axis=0)
    ring = np.vstack([ring, ring[:1]])
    if reverse:
        ring = ring[::-1]
    s, e = ring[:-1], ring[1:]
    vol = 0.09 * np.hypot(*(e - s).T)
    zeros = np.zeros(n, dtype=np.int64)
    return Deposits(s, e, np.zeros(n), np.full(n, 0.2), vol, zeros, zeros + 2)


def _b(d: Deposits) -> Beads:
    return Beads.of([d])


def test_a_few_beads_moved_by_hundredths_match():
    kept = _b(_deposits())
    assert match(kept, _b(_deposits(shift=0.06)))  # the volume follows the longer bead
    assert match(kept, _b(_deposits(shift=-0.06)))
    assert match(kept, _b(_deposits(scale=1.0 + 0.8 * NEAR_VOLUME)))
    assert match(kept, _b(_deposits(side=0.01)))  # the whole row sideways, by a hundredth


def test_the_same_beads_in_another_order_or_split_elsewhere_match():
    d = _deposits()
    order = np.random.default_rng(1).permutation(len(d.volume))
    shuffled = Deposits(*(getattr(d, f)[order] for f in ("start", "end", "z0", "height", "volume", "layer", "role")))
    assert match(_b(d), _b(shuffled))
    kept = _b(_loop(0))
    assert match(kept, _b(_loop(13)))  # the seam elsewhere
    assert match(kept, _b(_loop(13, reverse=True)))  # printed the other way round
    split = _loop(0)
    cut = split.start[5] + 0.37 * (split.end[5] - split.start[5])  # one bead in two: one bead more
    two = Deposits(
        np.vstack([split.start[:5], split.start[5], cut, split.start[6:]]),
        np.vstack([split.end[:5], cut, split.end[5], split.end[6:]]),
        *(np.concatenate([a[:6], a[5:]]) for a in (split.z0, split.height)),
        np.concatenate([split.volume[:5], [0.37 * split.volume[5], 0.63 * split.volume[5]], split.volume[6:]]),
        *(np.concatenate([a[:6], a[5:]]) for a in (split.layer, split.role)),
    )
    assert match(kept, _b(two))


def test_beads_moved_further_thicker_turned_or_more_do_not_match():
    kept = _b(_deposits())
    assert not match(kept, _b(_deposits(side=3.0 * NEAR_MM)))
    assert not match(kept, _b(_deposits(side=0.5 * NEAR_MM)))  # a few beads may move that far, not all
    assert not match(kept, _b(_deposits(scale=1.0 + 2.0 * NEAR_VOLUME, at=slice(None))))  # type: ignore[arg-type]
    assert not match(kept, _b(_deposits(n=51)))  # a bead more at the row's end
    assert not match(kept, _b(_deposits(n=49)))
    assert not match(_b(_loop(0)), _b(_loop(0, n=41)))  # other bead ends on the same square


def _patch(along_y: bool) -> Deposits:
    """A 2 mm square filled with five beads 0.4 mm apart, along x or along y."""
    c = np.arange(5) * 0.4 + 0.2
    s = np.column_stack([np.zeros(5), c])
    e = np.column_stack([np.full(5, 2.0), c])
    if along_y:
        s, e = s[:, ::-1], e[:, ::-1]
    z = np.zeros(5, dtype=np.int64)
    return Deposits(s, e, np.zeros(5), np.full(5, 0.2), np.full(5, 0.16), z, z + 4)


def test_the_same_plastic_in_another_direction_does_not_match():
    assert match(_b(_patch(False)), _b(_patch(False)))
    assert not match(_b(_patch(False)), _b(_patch(True)))

def test_the_near_key_names_layers_and_roles_not_beads():
    opts = StiffnessOptions()
    a, b = _deposits(), _deposits(shift=0.06)
    assert near_key("k", a, opts, None) == near_key("k", b, opts, None)
    assert near_key("k", a, opts, None) == near_key("k", _deposits(n=52), opts, None)  # counts: matched
    assert near_key("k", a, opts, None) != near_key("k", a, opts, StiffnessOptions(resolution=0.3))
    assert near_key("k", a, opts, None) != near_key("other analysis", a, opts, None)
    higher = _deposits()
    higher.height[:] = 0.25  # another layer height is another part
    assert near_key("k", a, opts, None) != near_key("k", higher, opts, None)
    moved_up = _deposits(n=52)
    moved_up.layer[-1] = 2  # a layer more
    assert near_key("k", a, opts, None) != near_key("k", moved_up, opts, None)
