"""Whether two files lay the same material in the same places: the near match of kept predictions.

A prediction kept in the run cache (:mod:`loadpath.stiffness.change`) is found again under the
exact bytes of the beads it was made of.  A re-export of the same part at other speeds, or a second
slice of it, lays nearly the same beads but not the same bytes.  PrusaSlicer 2.5 does not write the
same file twice: on a 40-layer gyroid gusset (``benchmarks/bench_latency.py``) two slices with the
same settings, and one at other speeds, had 33 of their 200 layer-and-role groups differ, most of
them the same beads in another order (an island's perimeters, the sparse lines), some with a loop's
seam elsewhere (one bead more), a few with vertices moved by up to 0.08 mm.  Bead for bead, none of
those match, and each re-export solved the part's two or three predictions again (2.9 of its 4.3 s).

So the match is on the material, not on the beads: :class:`Beads` keeps a file's bead ends, volumes,
layers and roles; :func:`match` cuts every bead at a 1 mm grid (:data:`CELL`, the model's mesh
size), spreads each piece's volume and its orientation (``cos 2 theta``, ``sin 2 theta`` weighted by
volume) over the four nearest grid nodes, per layer and role, and compares the two files node by
node.  Beads in another order, or split at another point, give the same sums; a bead moved by
``d`` mm shifts about ``d / CELL`` of its material to the next node.  Two files match when

* they have the same layers and roles at the same heights (:func:`group_bytes`, in the near key);
* each layer and role holds the same volume, and the same volume-weighted ``cos 2 theta`` and
  ``sin 2 theta``, within :data:`NEAR_VOLUME` of its volume;
* at every node of every layer and role, volume and both orientation sums differ by at most
  :data:`NODE_SHARE` of the larger volume plus :data:`NEAR_MM` mm of that group's median bead
  section (a bead end moved by a tenth of a millimetre, a line moved sideways by as much);
* over each layer and role, the node differences add up to at most :data:`NEAR_VOLUME` of its
  volume: a few beads may move by a tenth of a millimetre, not all of them (a whole layer moved
  sideways by ``d`` mm shifts ``2 d / CELL`` of its volume between nodes: about 1 % at 0.01 mm).

Orientation enters as ``2 theta``: a bead printed the other way round is the same bead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["NEAR_MM", "NEAR_VOLUME", "NODE_SHARE", "CELL", "Beads", "group_bytes", "match"]
__all__ += ["summary", "agrees"]

NEAR_MM = 0.1
"""Largest move of a bead's material (mm) with which a kept prediction is used for another file's beads."""

NEAR_VOLUME = 0.025
"""Largest change of a layer-and-role group's material, as a share of it: its volume, its
orientation sums, and the changes at its nodes added up.  The same engine paths spliced again, and
PrusaSlicer's own beads sliced again, changed a group by at most 0.8 % (the gusset's re-slice, its
swarm layout); two layouts of the same part, the level sets' and the swarm's, by 5.8-9.1 % (its
solid layers): half way between, nearer the first."""

NODE_SHARE = 0.15
"""Largest change of the material at one node, as a share of it (plus :data:`NEAR_MM` of bead).  The
same engine paths, spliced from another nozzle position, are printed the other way round and
simplified from the other end: their flow is set per vertex, so a node's volume moved by up to 10.5 %
(the gusset's re-slice, two nodes of 7,000), with every group's volume equal to 0.001 mm³."""

CELL = 1.0
"""Grid spacing of the comparison (mm): the stiffness model's mesh size (``StiffnessOptions``)."""

_DENSE = 1 << 23
"""Most grid nodes (groups times nodes per layer) summed into dense arrays; more are keyed sparsely."""


@dataclass(frozen=True)
class Beads:
    """A file's beads as the near match reads them (kept in the cache beside a prediction).

    Attributes
    ----------
    ends : (n, 4) float32, mm
        Start x, y and end x, y of each bead.
    volume : (n,) float32, mm³
    layer : (n,) int32
    role : (n,) int8
        :class:`loadpath.gcode.Role`.
    """

    ends: np.ndarray
    volume: np.ndarray
    layer: np.ndarray
    role: np.ndarray

    @classmethod
    def of(cls, parts) -> Beads:  # type: ignore[no-untyped-def]
        """The beads of an iterable of :class:`loadpath.stiffness.deposits.Deposits`."""
        deps = list(parts)
        if not deps:
            return cls(np.zeros((0, 4), np.float32), np.zeros(0, np.float32), np.zeros(0, np.int32),
                       np.zeros(0, np.int8))
        return cls(
            np.concatenate([np.hstack([d.start, d.end]) for d in deps]).astype(np.float32),
            np.concatenate([d.volume for d in deps]).astype(np.float32),
            np.concatenate([d.layer for d in deps]).astype(np.int32),
            np.concatenate([d.role for d in deps]).astype(np.int8),
        )

    def __len__(self) -> int:
        return len(self.volume)

    def only(self, keep: np.ndarray) -> Beads:
        """The beads where ``keep`` (n,) bool holds."""
        return Beads(self.ends[keep], self.volume[keep], self.layer[keep], self.role[keep])

    def codes(self) -> np.ndarray:
        """(n,) int64: each bead's layer-and-role group, ``layer * 256 + role``."""
        return self.layer.astype(np.int64) * 256 + self.role.astype(np.int64)


def group_bytes(layer: np.ndarray, role: np.ndarray, z0: np.ndarray, height: np.ndarray) -> bytes:
    """The layer-and-role groups of a file's beads with each group's lowest and highest bottom and
    height (to 0.1 µm), in group order: what the near key names exactly (bead counts and order do not
    enter it)."""
    code = np.asarray(layer, dtype=np.int64) * 256 + np.asarray(role, dtype=np.int64)
    if not len(code):
        return b"none"
    order = np.argsort(code, kind="stable")
    c = code[order]
    at = np.flatnonzero(np.r_[True, c[1:] != c[:-1]])
    z, h = np.asarray(z0, dtype=float)[order], np.asarray(height, dtype=float)[order]
    table = np.column_stack([
        c[at].astype(float),
        np.round(np.minimum.reduceat(z, at), 4), np.round(np.maximum.reduceat(z, at), 4),
        np.round(np.minimum.reduceat(h, at), 4), np.round(np.maximum.reduceat(h, at), 4),
    ])
    return table.tobytes()


def _pieces(b: Beads, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every bead cut where it crosses a grid line: each piece's group code, midpoint in grid units
    ``(m, 2)``, volume and unit orientation ``(cos 2 theta, sin 2 theta)`` ``(m, 2)``."""
    n = len(b)
    p0 = (b.ends[:, :2].astype(float) - origin) / CELL
    p1 = (b.ends[:, 2:].astype(float) - origin) / CELL
    d = p1 - p0
    length = np.hypot(*d.T)
    ts, owner = [np.zeros(n), np.ones(n)], [np.arange(n), np.arange(n)]
    for a in (0, 1):
        lo, hi = np.minimum(p0[:, a], p1[:, a]), np.maximum(p0[:, a], p1[:, a])
        k0 = np.floor(lo) + 1.0
        cnt = np.maximum(np.ceil(hi) - k0, 0).astype(np.int64)  # grid lines strictly inside
        who = np.repeat(np.arange(n), cnt)
        k = k0[who] + (np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt))
        ts.append(np.clip((k - p0[who, a]) / d[who, a], 0.0, 1.0))
        owner.append(who)
    t, who = np.concatenate(ts), np.concatenate(owner)
    order = np.lexsort((t, who))
    t, who = t[order], who[order]
    same = who[1:] == who[:-1]
    t0, t1, w = t[:-1][same], t[1:][same], who[:-1][same]
    keep = (t1 > t0) | (length[w] == 0)  # a bead of no length keeps its one piece
    t0, t1, w = t0[keep], t1[keep], w[keep]
    mid = p0[w] + (0.5 * (t0 + t1))[:, None] * d[w]
    vol = b.volume.astype(float)[w] * np.where(length[w] > 0, t1 - t0, 1.0)
    u = d / np.maximum(length, 1e-12)[:, None]
    turn = np.column_stack([u[:, 0] ** 2 - u[:, 1] ** 2, 2.0 * u[:, 0] * u[:, 1]])
    return b.codes()[w], mid, vol, turn[w]


def summary(b: Beads) -> tuple[np.ndarray, np.ndarray]:
    """A file's groups ``(g,)`` and each one's volume and orientation sums ``(g, 3)``: what
    :func:`agrees` compares (kept beside a prediction's near key, a few hundred bytes a layer)."""
    codes = np.unique(b.codes())
    return codes, _group_sums(b, codes)


def agrees(kept: tuple[np.ndarray, np.ndarray], beads: Beads) -> bool:
    """Whether ``beads`` have the groups of a :func:`summary` and, in each, its volume and mean
    direction within :data:`NEAR_VOLUME` of its volume: one pass over the beads, and most files
    that share a near key differ there (the slicer's file and a run's output: the same plastic,
    other directions; two density candidates: other places)."""
    codes, s0 = kept
    if not np.array_equal(codes, np.unique(beads.codes())):
        return False
    s1 = _group_sums(beads, codes)
    return bool(np.all(np.abs(s1 - s0) <= NEAR_VOLUME * s0[:, :1] + 1e-9))


def _group_digests(b: Beads, codes: np.ndarray) -> np.ndarray:
    """Each group's beads (ends and volumes, in order) as a digest ``(g,)`` (groups ``codes``, sorted)."""
    import hashlib

    code = b.codes()
    order = np.argsort(code, kind="stable")
    at = np.searchsorted(code[order], codes)
    stop = np.append(at[1:], len(order))
    ends, vol = b.ends[order], b.volume[order]
    return np.array([
        hashlib.blake2b(ends[i:j].tobytes() + vol[i:j].tobytes(), digest_size=16).digest()
        for i, j in zip(at.tolist(), stop.tolist(), strict=True)
    ], dtype=object)


def _group_sums(b: Beads, codes: np.ndarray) -> np.ndarray:
    """Each group's volume and its two orientation sums ``(g, 3)`` (groups ``codes``, sorted)."""
    g = np.searchsorted(codes, b.codes())
    d = (b.ends[:, 2:] - b.ends[:, :2]).astype(float)
    n2 = np.maximum(np.sum(d * d, axis=1), 1e-24)
    v = b.volume.astype(float)
    cols = (v, v * (d[:, 0] ** 2 - d[:, 1] ** 2) / n2, v * 2.0 * d[:, 0] * d[:, 1] / n2)
    return np.stack([np.bincount(g, c, minlength=len(codes)) for c in cols], axis=1)


def _nodes(code: np.ndarray, mid: np.ndarray, vol: np.ndarray, turn: np.ndarray, nx: int, ny: int):
    """Each piece spread over its four nearest grid nodes: node keys ``(4 m,)`` and the volume and its
    two orientation sums ``(4 m, 3)`` they receive."""
    base = np.floor(mid)
    f = mid - base
    i, j = base[:, 0].astype(np.int64), base[:, 1].astype(np.int64)
    keys, vals = [], []
    for di, wx in ((0, 1.0 - f[:, 0]), (1, f[:, 0])):
        for dj, wy in ((0, 1.0 - f[:, 1]), (1, f[:, 1])):
            keys.append((code * ny + (j + dj)) * nx + (i + di))
            v = vol * wx * wy
            vals.append(np.column_stack([v, v * turn[:, 0], v * turn[:, 1]]))
    return np.concatenate(keys), np.concatenate(vals)


def _binned(keys: np.ndarray, vals: np.ndarray, n: int) -> np.ndarray:
    """``vals`` ``(m, 3)`` summed per key ``(m,)`` into ``n`` bins: ``(n, 3)``."""
    return np.stack([np.bincount(keys, vals[:, q], minlength=n) for q in range(vals.shape[1])], axis=1)


def match(kept: Beads, beads: Beads) -> bool:
    """Whether ``beads`` lay the material of ``kept`` (module docstring).

    Both must already share their layer-and-role groups at the same heights (the near key says so);
    groups are compared by their codes here, so a group in one file only is a mismatch.
    """
    if len(kept) == 0 or len(beads) == 0:
        return len(kept) == len(beads)
    first = summary(kept)
    if not agrees(first, beads):  # the same groups, each with its volume and direction
        return False
    c0 = first[0]
    # groups whose beads are the very same, in the same order, match: the grid only for the rest
    differ = _group_digests(kept, c0) != _group_digests(beads, c0)
    if not differ.any():
        return True
    kept, beads = kept.only(np.isin(kept.codes(), c0[differ])), beads.only(np.isin(beads.codes(), c0[differ]))
    c0 = c0[differ]
    xy = np.concatenate([kept.ends.reshape(-1, 2), beads.ends.reshape(-1, 2)]).astype(float)
    origin = np.floor(xy.min(axis=0) / CELL) * CELL - CELL
    nx, ny = (int(v) + 3 for v in np.ceil((xy.max(axis=0) - origin) / CELL))
    sums = []
    for b in (kept, beads):
        code, mid, vol, turn = _pieces(b, origin)
        dense = np.searchsorted(c0, code)  # group index 0..g-1: the keys stay small
        sums.append(_nodes(dense, mid, vol, turn, nx, ny))
    (k0, v0), (k1, v1) = sums
    size = len(c0) * nx * ny
    if size <= _DENSE:
        a0, a1 = _binned(k0, v0, size), _binned(k1, v1, size)
        node_group = np.arange(size) // (nx * ny)
    else:
        keys, inv = np.unique(np.concatenate([k0, k1]), return_inverse=True)
        a0, a1 = _binned(inv[: len(k0)], v0, len(keys)), _binned(inv[len(k0) :], v1, len(keys))
        node_group = keys // (nx * ny)
    # each group's median bead section (volume per length; a bead under 0.05 mm counts as that long)
    length = np.maximum(np.hypot(*(kept.ends[:, 2:] - kept.ends[:, :2]).astype(float).T), 0.05)
    section = kept.volume.astype(float) / length
    g_of_bead = np.searchsorted(c0, kept.codes())
    order = np.lexsort((section, g_of_bead))
    starts = np.searchsorted(g_of_bead[order], np.arange(len(c0)))
    counts = np.bincount(g_of_bead, minlength=len(c0))
    median = section[order][starts + counts // 2]
    big = np.maximum(a0[:, 0], a1[:, 0])
    tol = NODE_SHARE * big + NEAR_MM * median[node_group] + 1e-9
    if np.any(np.abs(a1 - a0) > tol[:, None]):
        return False
    moved = np.bincount(node_group, np.abs(a1[:, 0] - a0[:, 0]), minlength=len(c0))
    total = np.bincount(node_group, a0[:, 0], minlength=len(c0))
    return bool(np.all(moved <= NEAR_VOLUME * total + 1e-9))
