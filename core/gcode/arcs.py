"""G2/G3 arcs as geometry: centre, sweep, and a sampling into chords, vectorized over all arcs.

Semantics follow Marlin's ``plan_arc`` (``G2`` clockwise, ``G3`` counter-clockwise seen from +Z):
the centre is the start point plus ``(I, J)``; with ``R`` instead, the centre lies on the chord's
perpendicular bisector, on the side given by the direction and the sign of ``R``; an arc that ends
where it starts is a full circle.  The radius is interpolated linearly from start to end (slicers
round the end point), Z and E linearly along the sweep (helical arcs), and the last chord ends
exactly at the written end point.  Chords deviate from the arc by at most ``TOL.arc_chord_mm``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Bools, Floats, Ints
from loadpath.tolerances import TOL

__all__ = ["ArcChords", "sample_arcs", "MAX_CHORDS"]

MAX_CHORDS = 1024
"""Upper bound on chords per arc (a full circle of radius 300 mm at 0.005 mm needs under 1000)."""


@dataclass(frozen=True)
class ArcChords:
    """Chords of a batch of arcs, in order.

    Attributes
    ----------
    arc : (m,) int64
        Index of the arc (into the batch) each chord belongs to.
    x0, y0, x1, y1 : (m,) float64, mm
        Chord end points.
    t0, t1 : (m,) float64
        Fraction of the arc's sweep at each end of the chord (for Z and E interpolation).
    """

    arc: Ints
    x0: Floats
    y0: Floats
    x1: Floats
    y1: Floats
    t0: Floats
    t1: Floats


def sample_arcs(
    x0: Floats, y0: Floats, x1: Floats, y1: Floats, i: Floats, j: Floats, r: Floats, clockwise: Bools
) -> ArcChords:
    """Sample arcs into chords.

    Parameters
    ----------
    x0, y0, x1, y1 : (k,) float, mm
        Start and end points.
    i, j : (k,) float, mm
        Centre offset from the start (NaN where the word is absent: taken as 0 when the other is given).
    r : (k,) float, mm
        Radius form (used where both ``i`` and ``j`` are NaN); negative selects the larger arc.
    clockwise : (k,) bool
        ``G2`` (True) or ``G3`` (False).

    Returns
    -------
    ArcChords
    """
    k = len(x0)
    use_ij = ~(np.isnan(i) & np.isnan(j))
    cx = x0 + np.where(use_ij, np.nan_to_num(i), 0.0)
    cy = y0 + np.where(use_ij, np.nan_to_num(j), 0.0)
    if (~use_ij).any():
        rr = np.nan_to_num(r)
        dx, dy = x1 - x0, y1 - y0
        d = np.hypot(dx, dy)
        h = np.sqrt(np.maximum((rr - 0.5 * d) * (rr + 0.5 * d), 0.0))
        side = np.where(clockwise ^ (rr < 0), -1.0, 1.0)
        safe = np.where(d > 0, d, 1.0)
        rx = (x0 + x1) / 2 + side * h * (-dy / safe)
        ry = (y0 + y1) / 2 + side * h * (dx / safe)
        cx = np.where(use_ij, cx, rx)
        cy = np.where(use_ij, cy, ry)
    r0 = np.hypot(x0 - cx, y0 - cy)
    r1 = np.hypot(x1 - cx, y1 - cy)
    a0 = np.arctan2(y0 - cy, x0 - cx)
    a1 = np.arctan2(y1 - cy, x1 - cx)
    raw = np.where(clockwise, a0 - a1, a1 - a0)
    sweep = np.mod(raw, 2 * np.pi)
    closed = (np.abs(x1 - x0) <= TOL.length_mm) & (np.abs(y1 - y0) <= TOL.length_mm)
    sweep = np.where(closed, 2 * np.pi, sweep)
    rmax = np.maximum(r0, r1)
    tol = TOL.arc_chord_mm
    step = np.where(rmax > tol, 2 * np.arccos(np.clip(1 - tol / np.maximum(rmax, tol), -1, 1)), np.pi)
    count = np.clip(np.ceil(sweep / np.maximum(step, 1e-9)), 1, MAX_CHORDS).astype(np.int64)
    count[rmax <= TOL.length_mm] = 1  # degenerate arc: a straight chord
    arc = np.repeat(np.arange(k), count)
    first = np.concatenate([[0], np.cumsum(count)[:-1]])
    kk = np.arange(len(arc)) - first[arc]
    t0 = kk / count[arc]
    t1 = (kk + 1) / count[arc]
    direction = np.where(clockwise, -1.0, 1.0)[arc]

    def point(t: Floats) -> tuple[Floats, Floats]:
        ang = a0[arc] + direction * sweep[arc] * t
        rad = r0[arc] + (r1[arc] - r0[arc]) * t
        return cx[arc] + rad * np.cos(ang), cy[arc] + rad * np.sin(ang)

    px0, py0 = point(t0)
    px1, py1 = point(t1)
    start = kk == 0
    px0[start], py0[start] = x0[arc[start]], y0[arc[start]]
    end = kk == count[arc] - 1
    px1[end], py1[end] = x1[arc[end]], y1[arc[end]]
    return ArcChords(arc=arc, x0=px0, y0=py0, x1=px1, y1=py1, t0=t0, t1=t1)
