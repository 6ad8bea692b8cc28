"""The line spacing (pitch) a slicer used for an infill block, estimated from the block's own moves.

Parallel-line patterns (rectilinear, lines, zigzag, grid, triangles, ...) are read directly: the
block's straight segments are histogrammed by direction (modulo 180 degrees, weighted by length); for
each direction that carries at least :data:`MIN_SHARE` of the length, the segments' offsets along the
direction's normal are sorted and the pitch is the median gap between neighbouring distinct lines:
each segment's neighbour is the nearest one beyond it that runs alongside it (gaps under a quarter
bead are the same line broken by a hole).  The block's pitch is that of its
dominant direction.

Curved patterns (gyroid, honeycomb, concentric, Hilbert, ...) have no dominant direction; their pitch
is then ``area / length`` of the block's region: parallel lines at pitch ``p`` over an area ``A`` have a
total length ``A / p``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats

__all__ = ["PitchEstimate", "estimate_pitch", "MIN_SHARE"]

MIN_SHARE = 0.2
"""Smallest share of a block's extruded length for a direction to count as one of its line families."""

_BIN_DEG = 1.0
_NEIGHBOURS = 16  # segments looked at beyond each one, in offset order, for its neighbouring line


@dataclass(frozen=True)
class PitchEstimate:
    """Pitch of a block's parallel lines.

    Attributes
    ----------
    pitch : float, mm
        Centre-to-centre distance of neighbouring lines of the dominant direction (NaN when the
        block has no dominant straight direction).
    angle : float, degrees
        Dominant line direction in [0, 180) (NaN when none).
    directions : tuple of (angle_deg, pitch_mm, share)
        Every line family found (grid: two, triangles: three).
    straight_share : float
        Share of the extruded length in the families found (0 for curved patterns).
    """

    pitch: float
    angle: float
    directions: tuple[tuple[float, float, float], ...]
    straight_share: float

    @property
    def found(self) -> bool:
        """True when the block has a dominant direction with a measured pitch."""
        return bool(np.isfinite(self.pitch))


_NONE = PitchEstimate(float("nan"), float("nan"), (), 0.0)


def estimate_pitch(x0: Floats, y0: Floats, x1: Floats, y1: Floats, width: float) -> PitchEstimate:
    """Estimate the pitch of one block's lines.

    Parameters
    ----------
    x0, y0, x1, y1 : (n,) float, mm
        The block's extruding segments.
    width : float, mm
        The block's flow width (segments shorter than two widths are connectors, not lines; offsets
        closer than a quarter width are one line).

    Returns
    -------
    PitchEstimate
    """
    dx, dy = x1 - x0, y1 - y0
    seg = np.hypot(dx, dy)
    total = float(seg.sum())
    keep = seg >= 2.0 * width
    if total <= 0 or not keep.any():
        return _NONE
    x0, y0, x1, y1 = x0[keep], y0[keep], x1[keep], y1[keep]
    dx, dy, seg = dx[keep], dy[keep], seg[keep]
    ang = np.degrees(np.arctan2(dy, dx)) % 180.0
    nb = int(round(180.0 / _BIN_DEG))
    hist = np.bincount(np.minimum((ang / _BIN_DEG).astype(np.int64), nb - 1), weights=seg, minlength=nb)
    # a family may straddle two bins (and 0/180): sum each bin with its right neighbour (cyclic)
    pair = hist + np.roll(hist, -1)
    families = []
    used = np.zeros(nb, dtype=bool)
    for b in np.argsort(pair)[::-1]:
        if pair[b] < MIN_SHARE * total:
            break
        if used[b] or used[(b + 1) % nb]:
            continue
        used[[(b - 1) % nb, b, (b + 1) % nb, (b + 2) % nb]] = True
        centre = (b + 1) * _BIN_DEG  # the edge between the two bins
        rel = (ang - centre + 90.0) % 180.0 - 90.0
        sel = np.abs(rel) <= 1.5 * _BIN_DEG
        if not sel.any():
            continue
        theta = np.radians(centre + np.average(rel[sel], weights=seg[sel]))
        gaps = _neighbour_gaps(x0[sel], y0[sel], x1[sel], y1[sel], theta, 0.25 * width)
        if len(gaps) == 0:
            continue
        families.append((float(np.degrees(theta) % 180.0), float(np.median(gaps)),
                         float(seg[sel].sum() / total)))
    if not families:
        return _NONE
    families.sort(key=lambda f: -f[2])
    return PitchEstimate(families[0][1], families[0][0], tuple(families), float(sum(f[2] for f in families)))


def _neighbour_gaps(x0: Floats, y0: Floats, x1: Floats, y1: Floats, theta: float, same: float) -> Floats:
    """Offset of every segment of one direction to its next neighbouring line, mm.

    The neighbour is the nearest segment beyond it (offset across the direction ``theta``, radians)
    that runs alongside it: their extents along the direction overlap.  Parallel segments that do not
    run alongside each other are not neighbouring lines of a fill: OrcaSlicer's crosshatch infill
    prints staircases of short segments whose parallel steps stand 0.71 mm apart across the
    direction and 4 mm along it, at 15 % density and 0.45 mm width (OrcaSlicer 2.3.1 P1S cube, layer
    95).  Offsets closer than ``same`` are one line broken by a hole.  Segments without a neighbour
    among the next :data:`_NEIGHBOURS` in offset order give none.
    """
    c, s = np.cos(theta), np.sin(theta)
    off = -s * (x0 + x1) / 2 + c * (y0 + y1) / 2
    a0, a1 = c * x0 + s * y0, c * x1 + s * y1
    order = np.argsort(off)
    off, lo, hi = off[order], np.minimum(a0, a1)[order], np.maximum(a0, a1)[order]
    gaps = np.full(len(off), np.nan)
    for k in range(1, min(_NEIGHBOURS, len(off) - 1) + 1):
        g = off[k:] - off[:-k]
        alongside = np.minimum(hi[k:], hi[:-k]) - np.maximum(lo[k:], lo[:-k]) > 0
        new = alongside & (g > same) & np.isnan(gaps[:-k])
        gaps[:-k][new] = g[new]
    return gaps[np.isfinite(gaps)]
