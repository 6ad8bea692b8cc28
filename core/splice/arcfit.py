"""Arc fitting for the new paths: runs of a chain's segments written as one ``G2``/``G3`` move.

Only where the file's own settings say the printer takes arcs (:func:`arcs_allowed`): PrusaSlicer
2.6+ writes ``; arc_fitting = emit_center`` (``disabled`` otherwise), OrcaSlicer and Bambu Studio
``; enable_arc_fitting = 1``.  PrusaSlicer 2.5 has no such key and CuraEngine none at all
(``slicer-conventions.md`` §1.2, §2.4): no arcs there, whatever the firmware flavour.

Per chain (:func:`fit_arcs`, greedy, in print order): from a segment, the arc grows while

- the segments print alike: one width, one feedrate, one extrusion per mm (one bead run's piece,
  :mod:`loadpath.splice.beadruns`), so the arc extrudes their filament at the same flow;
- the circle through the first, middle and last vertex passes within ``tol`` of every vertex, and
  within ``chord`` of every segment's midpoint: the chords are the engine's path simplified
  within the bead runs' bound (the vertices are the path's own), so with ``chord`` that bound the
  arc stays in the band about the path the chords were allowed;
- every segment turns the same way, the sweep stays below ``max_sweep`` and the radius between
  ``min_radius`` and ``max_radius`` (straighter runs are one ``G1`` already).

An arc spans at least ``min_segments`` segments (fewer save nothing: a ``G2`` line is ~1.4x a
``G1`` line).  Semantics of the written move as :mod:`loadpath.gcode.arcs` reads it (Marlin's
``plan_arc``): the centre is the start plus ``(I, J)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats, Points2

__all__ = ["Arc", "ArcOptions", "arcs_allowed", "fit_arcs"]


def arcs_allowed(config: Mapping[str, str]) -> bool:
    """Whether the file's settings let the printer take ``G2``/``G3`` (module docstring).

    Examples
    --------
    >>> arcs_allowed({"arc_fitting": "emit_center"}), arcs_allowed({"arc_fitting": "disabled"})
    (True, False)
    >>> arcs_allowed({"enable_arc_fitting": "1"}), arcs_allowed({"gcode_flavor": "marlin2"})
    (True, False)
    """
    prusa = str(config.get("arc_fitting", "")).strip().lower()
    orca = str(config.get("enable_arc_fitting", "")).strip().lower()
    return prusa not in ("", "disabled", "0", "false") or orca in ("1", "true")


@dataclass(frozen=True)
class ArcOptions:
    """Bounds of :func:`fit_arcs`.

    Attributes
    ----------
    tol : float, mm
        Largest distance of the arc from the vertices it replaces.
    chord : float, mm
        Largest distance of the arc from the midpoints of the segments it replaces (0: ``tol``);
        the splicer sets the bead runs' simplification bound.
    min_segments : int
    max_sweep : float, degrees
    min_radius, max_radius : float, mm
    """

    tol: float = 0.02
    chord: float = 0.0
    min_segments: int = 3
    max_sweep: float = 120.0
    min_radius: float = 1.0
    max_radius: float = 500.0


@dataclass(frozen=True)
class Arc:
    """Segments ``[first, stop)`` of a chain as one arc about ``centre`` (mm); ``ccw``: ``G3``."""

    first: int
    stop: int
    centre: tuple[float, float]
    ccw: bool


def _circle(a, b, c):
    ax, ay = a
    bx, by = b
    cx, cy = c
    d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(d) < 1e-12:
        return None
    a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d
    uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d
    return ux, uy, math.hypot(ax - ux, ay - uy)


def _fits(p: np.ndarray, opts: ArcOptions):
    """The circle ``(ux, uy, r, ccw)`` through the polyline ``p`` (k + 1, 2) within the bounds, or None."""
    c = _circle(p[0], p[len(p) // 2], p[-1])
    if c is None:
        return None
    ux, uy, r = c
    if not opts.min_radius <= r <= opts.max_radius:
        return None
    d = p[1:] - p[:-1]
    cross = d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0]
    if not (np.all(cross > 0) or np.all(cross < 0)):
        return None
    if np.max(np.abs(np.hypot(p[:, 0] - ux, p[:, 1] - uy) - r)) > opts.tol:
        return None
    mids = 0.5 * (p[1:] + p[:-1])
    if np.max(np.abs(np.hypot(mids[:, 0] - ux, mids[:, 1] - uy) - r)) > max(opts.chord, opts.tol):
        return None
    a0 = math.atan2(p[0, 1] - uy, p[0, 0] - ux)
    ang = np.unwrap(np.arctan2(p[:, 1] - uy, p[:, 0] - ux) - a0)
    ccw = bool(cross[0] > 0)
    sweep = math.degrees(abs(ang[-1]))
    step = np.diff(ang)
    if sweep > opts.max_sweep or not (np.all(step > 0) if ccw else np.all(step < 0)):
        return None
    return ux, uy, r, ccw


def fit_arcs(
    points: Points2, filament: Floats, width: Floats, feedrate: Floats, opts: ArcOptions
) -> list[Arc]:
    """The arcs of one chain, in order, not overlapping (module docstring).

    Parameters
    ----------
    points : (n + 1, 2) float, mm
    filament, width, feedrate : (n,) float
        Per segment: mm of filament, mm, mm/min.
    opts : ArcOptions

    Returns
    -------
    list of Arc
    """
    p = np.asarray(points, dtype=float)
    n = len(p) - 1
    if n < opts.min_segments:
        return []
    seg = np.hypot(*(p[1:] - p[:-1]).T)
    dens = np.asarray(filament, dtype=float) / np.maximum(seg, 1e-12)
    w = np.asarray(width, dtype=float)
    f = np.asarray(feedrate, dtype=float)
    # segments that print like the one before them
    alike = np.ones(n, dtype=bool)
    same_flow = np.abs(dens[1:] - dens[:-1]) <= 1e-9 + 1e-6 * dens[:-1]
    alike[1:] = (w[1:] == w[:-1]) & (f[1:] == f[:-1]) & same_flow
    out: list[Arc] = []
    i = 0
    while i + opts.min_segments <= n:
        j = i + opts.min_segments  # segments [i, j)
        if not alike[i + 1 : j].all():
            i += 1
            continue
        best = _fits(p[i : j + 1], opts)
        if best is None:
            i += 1
            continue
        while j < n and alike[j]:
            got = _fits(p[i : j + 2], opts)
            if got is None:
                break
            best, j = got, j + 1
        out.append(Arc(i, j, (best[0], best[1]), best[3]))
        i = j
    return out
