"""Occupancy grid of the paths laid so far: which path owns each small cell of the layer.

The swarm's chain structure keeps neighbours apart, but nothing in the paper stops a front that
wraps around a pin hole from meeting itself, or a later swarm from meeting an earlier one at a
point the domain's boundary did not see.  The grid is the safety net: a cell is ``pitch / 3``
wide, so two points in one cell are closer than ``0.48 pitch``; an agent may not move into (or be
spawned in) a cell owned by another path.
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
    """

    bounds: tuple[float, float, float, float]
    cell: float
    owner: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        x0, y0, x1, y1 = self.bounds
        self.origin = np.array([x0 - 2 * self.cell, y0 - 2 * self.cell])
        nx = int(np.ceil((x1 - x0) / self.cell)) + 5
        ny = int(np.ceil((y1 - y0) / self.cell)) + 5
        self.owner = np.full((nx, ny), -1, dtype=np.int64)
        self.point = np.zeros((nx, ny, 2))
        r = np.arange(-2, 3)
        self._ring = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)

    def _index(self, points: Points2) -> tuple[Ints, Ints, Bools]:
        ij = np.floor((np.asarray(points, dtype=float).reshape(-1, 2) - self.origin) / self.cell)
        ij = np.nan_to_num(ij, nan=-1.0)
        ok = (ij[:, 0] >= 0) & (ij[:, 1] >= 0) & (ij[:, 0] < self.owner.shape[0]) & (ij[:, 1] < self.owner.shape[1])
        i = np.where(ok, ij[:, 0], 0).astype(np.int64)
        j = np.where(ok, ij[:, 1], 0).astype(np.int64)
        return i, j, ok

    def free_for(self, points: Points2, path_id: Ints) -> Bools:
        """Whether each point's cell is empty or owned by the given path, (n,) bool."""
        i, j, ok = self._index(points)
        own = self.owner[i, j]
        return ok & ((own < 0) | (own == np.asarray(path_id)))

    def _samples(self, a: Points2, b: Points2) -> tuple[np.ndarray, int]:
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        b = np.asarray(b, dtype=float).reshape(-1, 2)
        length = float(np.max(np.linalg.norm(b - a, axis=1), initial=0.0))
        k = max(2, int(np.ceil(2.0 * length / self.cell)) + 1)
        s = np.linspace(0.0, 1.0, k)
        return a[:, None, :] + s[None, :, None] * (b - a)[:, None, :], k

    def free_path(self, a: Points2, b: Points2, path_id: Ints) -> Bools:
        """Whether every cell along segments ``a -> b`` is empty or the given path's, (n,) bool."""
        pts, k = self._samples(a, b)
        if not len(pts):
            return np.zeros(0, dtype=bool)
        ids = np.repeat(np.asarray(path_id), k)
        return self.free_for(pts.reshape(-1, 2), ids).reshape(-1, k).all(axis=1)

    def mark(self, a: Points2, b: Points2, path_id: Ints) -> None:
        """Give the cells along segments ``a -> b`` to their paths (sampled every half cell)."""
        pts, k = self._samples(a, b)
        if not len(pts):
            return
        ids = np.repeat(np.asarray(path_id), k)
        flat = pts.reshape(-1, 2)
        i, j, ok = self._index(flat)
        self.owner[i[ok], j[ok]] = ids[ok]
        self.point[i[ok], j[ok]] = flat[ok]

    def clear_of(self, points: Points2, path_id: Ints, radius: float) -> Bools:
        """Whether no point of another path lies within ``radius`` (at most two cells) of each point.

        Distances are measured to the trail samples kept in the cells (one per cell, every half
        cell along the trail), so the test errs by at most a quarter cell.
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        i, j, ok = self._index(p)
        ii = np.clip(i[:, None] + self._ring[None, :, 0], 0, self.owner.shape[0] - 1)
        jj = np.clip(j[:, None] + self._ring[None, :, 1], 0, self.owner.shape[1] - 1)
        own = self.owner[ii, jj]
        other = (own >= 0) & (own != np.asarray(path_id)[:, None])
        d = np.linalg.norm(self.point[ii, jj] - p[:, None, :], axis=2)
        return ok & ~np.any(other & (d < radius), axis=1)
