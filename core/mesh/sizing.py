"""Default mesh sizes from the part's size and the infill pitch, and where to refine.

The engines resolve the field at the pitch (a path every ``pitch`` mm), so elements much smaller
than the pitch buy nothing in the bulk; stress concentrations (holes, re-entrant corners) need finer
elements to get the peak right (benchmarks.md §4), and the loaded and supported boundary is where
the load enters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Region
from loadpath.areal import polygons_of

__all__ = ["MeshSize", "default_mesh_size", "reentrant_corners", "DEFAULT_PITCH", "DEFAULT_MAX_TETS"]

DEFAULT_PITCH = 0.45
"""mm: the pitch of a 0.4 mm nozzle's solid infill, when the caller does not know it."""

DEFAULT_MAX_TETS = 60_000
"""Element budget of a default 3D mesh (quadratic tetrahedra).

The field only steers paths a pitch apart, so it needs the stress resolved to a few millimetres,
graded at holes and corners; 60 000 tet10 (about 90 000 nodes) solve in well under a minute on one
core (``benchmarks/bench_fea.py``). Parts that need more are meshed coarser (``loadpath.fea.build_mesh``).
"""


@dataclass(frozen=True)
class MeshSize:
    """Element sizes.

    Attributes
    ----------
    h : float, mm
        Size in the bulk.
    h_min : float, mm
        Size at holes and re-entrant corners.
    h_bc : float, mm
        Size along loaded and supported boundary.
    grading : float
        Growth of the size per mm of distance from a refined feature (0.3: +0.3 mm per mm).
    """

    h: float
    h_min: float
    h_bc: float
    grading: float = 0.3

    def __post_init__(self) -> None:
        for name in ("h", "h_min", "h_bc", "grading"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"mesh size {name} = {v!r} must be a positive number of mm")
        object.__setattr__(self, "h_min", min(self.h_min, self.h))
        object.__setattr__(self, "h_bc", min(max(self.h_bc, self.h_min), self.h))

    @classmethod
    def uniform(cls, h: float) -> MeshSize:
        """Return the same size everywhere (no grading)."""
        return cls(h, h, h)


def default_mesh_size(outline: Region, pitch: float | None = None) -> MeshSize:
    """Mesh sizes derived from the part and the infill pitch.

    ``h = clip(short side of the bounding box / 12, 2 pitch, 20 pitch)``;
    ``h_min = clip(smallest hole circumference / 40, pitch / 2, h / 3)`` (``h / 4`` without holes);
    ``h_bc = 2 h_min``.  For the 150 x 36 mm open-hole specimen and a 0.45 mm pitch: 3.0, 0.47, 0.94 mm.

    Parameters
    ----------
    outline : shapely Polygon or MultiPolygon, mm
        The part outline (the largest one for a 3D part).
    pitch : float, mm, optional
        The infill pitch; default :data:`DEFAULT_PITCH`.

    Returns
    -------
    MeshSize
    """
    p = DEFAULT_PITCH if pitch is None else float(pitch)
    x0, y0, x1, y1 = outline.bounds
    short = max(min(x1 - x0, y1 - y0), 1e-3)
    h = float(np.clip(short / 12.0, 2.0 * p, 20.0 * p))
    holes = [r.length for poly in polygons_of(outline) for r in poly.interiors]
    target = min(holes) / 40.0 if holes else h / 4.0
    h_min = float(np.clip(target, 0.5 * p, h / 3.0))
    return MeshSize(h, h_min, min(2.0 * h_min, h))


def reentrant_corners(outline: Region, min_turn_deg: float = 20.0) -> np.ndarray:
    """Vertices where the material's interior angle exceeds ``180 + min_turn_deg`` degrees.

    Parameters
    ----------
    outline : shapely Polygon or MultiPolygon
    min_turn_deg : float
        Smaller turns (polygonised arcs) are not corners.

    Returns
    -------
    (n, 2) float, mm
    """
    out = []
    lim = math.sin(math.radians(min_turn_deg))
    for poly in polygons_of(
        shapely.geometry.polygon.orient(outline, 1.0) if outline.geom_type == "Polygon" else outline
    ):
        poly = shapely.geometry.polygon.orient(poly, 1.0)
        for ring in [poly.exterior, *poly.interiors]:
            c = np.asarray(ring.coords)[:-1, :2]
            if len(c) < 3:
                continue
            a = c - np.roll(c, 1, axis=0)
            b = np.roll(c, -1, axis=0) - c
            la = np.linalg.norm(a, axis=1)
            lb = np.linalg.norm(b, axis=1)
            ok = (la > 0) & (lb > 0)
            cross = np.where(ok, (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) / np.where(ok, la * lb, 1.0), 0.0)
            # material on the left of every ring (exterior CCW, holes CW): a right turn is re-entrant
            out.append(c[cross < -lim])
    return np.concatenate(out) if out else np.zeros((0, 2))
