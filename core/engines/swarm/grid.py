"""Occupancy grid of the paths laid so far: which path owns each small cell of the layer.

The swarm's chain structure keeps neighbours apart, but nothing in the paper stops a front that
wraps around a pin hole from meeting itself, or a later swarm from meeting an earlier one at a
point the domain's boundary did not see.  The grid is the safety net: a cell is ``pitch / 3``
wide, so two points in one cell are closer than ``0.48 pitch``; an agent may not move into (or be
spawned in) a cell owned by another path.

The cells are kept in flat arrays and addressed with one flat index per point (a 1-D ``take`` is
several times faster than 2-D fancy indexing at the sizes of a step); the grid extends ``pad``
cells beyond the region's bounds and points beyond that are clamped to its edge cells, which no
path ever owns.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from loadpath._typing import Bools, Ints, Points2

__all__ = ["Occupancy"]


@dataclass
class Occupancy:
    """Cells of side ``cell`` over ``bounds``; each holds the id of the last path through it, or -1.

    Parameters
    ----------
    bounds : (xmin, ymin, xmax, ymax), mm
    cell : float, mm
    pad : int
        Cells added on every side (at least 3: the ring of :meth:`clear_of` plus one).
    """

    bounds: tuple[float, float, float, float]
    cell: float
    pad: int = 12
    owner: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        x0, y0, x1, y1 = self.bounds
        pad = max(3, int(self.pad))
        self.origin = np.array([x0 - pad * self.cell, y0 - pad * self.cell])
        self.nx = int(np.ceil((x1 - x0) / self.cell)) + 2 * pad + 1
        self.ny = int(np.ceil((y1 - y0) / self.cell)) + 2 * pad + 1
        self.owner = np.full(self.nx * self.ny, -1, dtype=np.int64)
        self.point = np.zeros((self.nx * self.ny, 2))
        self._hi = np.array([self.nx - 3, self.ny - 3], dtype=float)
        self._stride = np.array([self.ny, 1], dtype=np.intp)
        r = np.arange(-2, 3)
        ring = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)
        self._ring = ring @ self._stride
        self._fractions: dict[int, np.ndarray] = {}

    def _index(self, points: Points2) -> np.ndarray:
        """Flat cell index of each point (clamped two cells inside the grid's edge), (n,) int."""
        f = np.minimum(np.maximum(np.floor((points - self.origin) / self.cell), 2.0), self._hi)
        return f.astype(np.intp) @ self._stride

    def free_for(self, points: Points2, path_id: Ints) -> Bools:
        """Whether each point's cell is empty or owned by the given path, (n,) bool."""
        own = self.owner[self._index(np.asarray(points, dtype=float).reshape(-1, 2))]
        return (own < 0) | (own == np.asarray(path_id))

    def _samples(self, a: Points2, b: Points2) -> tuple[np.ndarray, int]:
        """Points every half cell (at most) along segments ``a -> b``, (n * k, 2), and ``k``."""
        d = b - a
        length = float(np.sqrt(np.max(np.add.reduce(d * d, axis=1), initial=0.0)))
        k = max(2, int(np.ceil(2.0 * length / self.cell)) + 1)
        s = self._fractions.get(k)
        if s is None:
            s = self._fractions[k] = np.linspace(0.0, 1.0, k)[None, :, None]
        return (a[:, None, :] + s * d[:, None, :]).reshape(-1, 2), k

    def cells(self, a: Points2, b: Points2) -> tuple[np.ndarray, np.ndarray]:
        """Cells and sample points along segments ``a -> b``: ``(n, k)`` flat indices, ``(n, k, 2)`` mm."""
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        pts, k = self._samples(a, np.asarray(b, dtype=float).reshape(-1, 2))
        return self._index(pts).reshape(-1, k), pts.reshape(-1, k, 2)

    def free_cells(self, idx: np.ndarray, path_id: Ints) -> Bools:
        """Whether all cells of each row of ``idx`` (:meth:`cells`) are empty or the path's, (n,) bool."""
        own = self.owner[idx]
        return np.all((own < 0) | (own == np.asarray(path_id)[:, None]), axis=1)

    def mark_cells(self, idx: np.ndarray, pts: np.ndarray, path_id: Ints) -> None:
        """Give the cells of :meth:`cells` to their paths."""
        self.owner[idx.ravel()] = np.repeat(np.asarray(path_id), idx.shape[1])
        self.point[idx.ravel()] = pts.reshape(-1, 2)

    def free_path(self, a: Points2, b: Points2, path_id: Ints) -> Bools:
        """Whether every cell along segments ``a -> b`` is empty or the given path's, (n,) bool."""
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        if not len(a):
            return np.zeros(0, dtype=bool)
        pts, k = self._samples(a, np.asarray(b, dtype=float).reshape(-1, 2))
        own = self.owner[self._index(pts)].reshape(-1, k)
        return np.all((own < 0) | (own == np.asarray(path_id)[:, None]), axis=1)

    def mark(self, a: Points2, b: Points2, path_id: Ints) -> None:
        """Give the cells along segments ``a -> b`` to their paths (sampled every half cell)."""
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        if not len(a):
            return
        pts, k = self._samples(a, np.asarray(b, dtype=float).reshape(-1, 2))
        idx = self._index(pts)
        self.owner[idx] = np.repeat(np.asarray(path_id), k)
        self.point[idx] = pts

    def clear_of(self, points: Points2, path_id: Ints, radius: float) -> Bools:
        """Whether no point of another path lies within ``radius`` (at most two cells) of each point.

        Distances are measured to the trail samples kept in the cells (one per cell, every half
        cell along the trail), so the test errs by at most a quarter cell.
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        kk = self._index(p)[:, None] + self._ring[None, :]
        own = self.owner[kk]
        other = (own >= 0) & (own != np.asarray(path_id)[:, None])
        out = np.ones(len(p), dtype=bool)
        if not np.any(other):
            return out
        r, c = np.nonzero(other)
        d = self.point[kk[r, c]] - p[r]
        out[r[np.add.reduce(d * d, axis=1) < radius * radius]] = False
        return out
