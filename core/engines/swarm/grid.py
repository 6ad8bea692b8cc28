"""Occupancy grid of the paths laid so far: which path owns each small cell of the layer.

The swarm's chain structure keeps neighbours apart, but nothing in the paper stops a front that
wraps around a pin hole from meeting itself, or a later swarm from meeting an earlier one at a
point the domain's boundary did not see.  The grid is the safety net: a cell is ``pitch / 3``
wide, so two points in one cell are closer than ``0.48 pitch``; an agent may not move into (or be
spawned in) a cell owned by another path.

The cells are kept in flat arrays (owner and the last trail sample per cell); the grid extends
``pad`` cells beyond the region's bounds and points beyond that are clamped to its edge cells,
which no path ever owns.  The queries are the compiled kernels of :mod:`.kernel_geom`, which the
swarm's step calls directly on :attr:`Occupancy.data`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from loadpath._typing import Bools, Ints, Points2
from loadpath.engines.finish import kernel_geom as kg

__all__ = ["Occupancy"]


def _pts(points: Points2) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))


def _ids(path_id: Ints, n: int) -> np.ndarray:
    return np.array(np.broadcast_to(np.asarray(path_id, dtype=np.int64), (n,)))  # writeable, contiguous


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
        r = np.arange(-2, 3)
        ring = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)
        self.data = kg.GridData(
            owner=self.owner,
            point=self.point,
            origin=self.origin,
            cell=float(self.cell),
            ny=int(self.ny),
            hi=np.array([self.nx - 3, self.ny - 3], dtype=float),
            ring=np.ascontiguousarray(ring @ np.array([self.ny, 1], dtype=np.int64)),
        )

    def free_for(self, points: Points2, path_id: Ints) -> Bools:
        """Whether each point's cell is empty or owned by the given path, (n,) bool."""
        p = _pts(points)
        return kg.grid_free_for(self.data, p, _ids(path_id, len(p)))

    def free_path(self, a: Points2, b: Points2, path_id: Ints) -> Bools:
        """Whether every cell along segments ``a -> b`` (sampled every half cell) is free, (n,) bool."""
        a = _pts(a)
        return kg.grid_free_path(self.data, a, _pts(b), _ids(path_id, len(a)))

    def mark(self, a: Points2, b: Points2, path_id: Ints) -> None:
        """Give the cells along segments ``a -> b`` to their paths (sampled every half cell)."""
        a = _pts(a)
        kg.grid_mark(self.data, a, _pts(b), _ids(path_id, len(a)))

    def clear_of(self, points: Points2, path_id: Ints, radius: float) -> Bools:
        """Whether no point of another path lies within ``radius`` (at most two cells) of each point.

        Distances are measured to the trail samples kept in the cells (one per cell, every half
        cell along the trail), so the test errs by at most a quarter cell.
        """
        p = _pts(points)
        return kg.grid_clear_of(self.data, p, _ids(path_id, len(p)), float(radius))
