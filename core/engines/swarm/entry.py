"""Where the load enters a layer: the start line of the first swarm (paper Sec. III-A).

The paper starts its swarm "at the location where the largest external force is applied".  The
load case says which boundary each load selector picked
(:meth:`loadpath.loadcase.resolve.ResolvedBody.load_entry`), but a selector picks more than the
faces the force goes through: ``side = "x_max", within = 10`` also picks 10 mm of each long side of
the specimen, where a pull along x is a shear, and ``hole_near`` picks the whole hole while a pin
presses only on the half that faces the force (the FEA's cosine bearing distribution,
:mod:`loadpath.fea.boundary`).  :func:`load_entry` keeps the pieces of the picked boundary where
the load is mostly normal to it:

* force on a side or box selection: segments whose outward normal ``n`` has ``|n . F| >= cos 60 deg |F|``;
* bearing load (force on a hole): segments with ``-n . F >= cos 60 deg |F|``, the middle two thirds of
  the pressed half (the load's cosine weight is at least one half there);
* pressure: the whole selection.

If the filter leaves nothing (a force along the picked faces) the whole selection is kept.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

__all__ = ["load_entry", "NORMAL_COS"]

NORMAL_COS = 0.5
"""Smallest cosine between the load and the boundary normal for a segment to count as entry."""


def _segments(lines: BaseGeometry) -> tuple[np.ndarray, np.ndarray]:
    a, b = [], []
    for g in shapely.get_parts(lines):
        c = shapely.get_coordinates(g)
        if len(c) >= 2:
            a.append(c[:-1])
            b.append(c[1:])
    if not a:
        return np.zeros((0, 2)), np.zeros((0, 2))
    return np.concatenate(a), np.concatenate(b)


def load_entry(resolved: object, z: float | None = None) -> BaseGeometry | None:
    """Find the boundary lines through which the loads enter the layer at height ``z``.

    Parameters
    ----------
    resolved : loadpath.loadcase.ResolvedBody
        The load case applied to the body (its ``loads`` and ``body``).
    z : float, mm, optional
        Layer height (the middle of the layer); None: the whole body.

    Returns
    -------
    shapely MultiLineString or None
        In the bed frame (xy); None when no load acts at this height.
    """
    pieces = []
    for load, sel in resolved.loads:  # type: ignore[attr-defined]
        lines = sel.lines if z is None else sel.lines_at(z)
        if lines is None or lines.is_empty:
            continue
        if load.force is None:
            pieces.append(lines)
            continue
        f = np.asarray(load.force[:2], dtype=float)
        fn = float(np.linalg.norm(f))
        a, b = _segments(lines)
        if fn == 0.0 or not len(a):
            pieces.append(lines)
            continue
        d = b - a
        length = np.linalg.norm(d, axis=1)
        ok = length > 0
        a, b, d, length = a[ok], b[ok], d[ok], length[ok]
        left = np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None]
        mid = 0.5 * (a + b)
        slab = resolved.body.slab_at(z) if z is not None else None  # type: ignore[attr-defined]
        outline = slab.outline if slab is not None else resolved.body.slabs[0].outline  # type: ignore[attr-defined]
        probe = mid + 1e-3 * np.maximum(length, 1.0)[:, None] * left
        left_inside = shapely.contains_xy(outline, probe[:, 0], probe[:, 1])
        outward = np.where(left_inside[:, None], -left, left)
        c = outward @ (f / fn)
        keep = (-c >= NORMAL_COS) if load.is_bearing else (np.abs(c) >= NORMAL_COS)
        if not np.any(keep):
            pieces.append(lines)
            continue
        segs = shapely.linestrings(np.stack([a[keep], b[keep]], axis=1))
        pieces.append(shapely.line_merge(shapely.union_all(segs)))
    if not pieces:
        return None
    return shapely.line_merge(shapely.union_all(pieces))
