"""Where the report's close-up looks: a window that always has material in view.

Stress concentrates at holes, so the close-up frames the largest one; a lightening cut-out larger
than the window once put the whole window inside the hole (nothing to draw, and a crash after the
G-code had been written).
"""

from __future__ import annotations

import numpy as np
import shapely
from loadpath.field import StressField

__all__ = ["detail_centre"]


def _most_stressed(field_: StressField, pts: np.ndarray) -> np.ndarray | None:
    """The point of ``pts`` where ``|s|`` is largest (None when the field is valid at none)."""
    if len(pts) == 0:
        return None
    smp = field_.sample(pts)
    mass = np.where(smp.valid, np.nan_to_num(smp.mass, nan=-np.inf), -np.inf)
    return pts[int(np.argmax(mass))] if np.isfinite(mass.max()) else pts[len(pts) // 2]


def detail_centre(region, field_: StressField, ww: float, wh: float) -> np.ndarray:
    """Centre of the close-up window (``ww`` x ``wh`` mm): always a point with material in view.

    The largest hole when one is small enough to sit inside the window with its wall around it;
    a hole larger than the window (a lightening cut-out) would put the whole window inside the
    hole, so then the most stressed point of its edge.  Without a hole, the most stressed point of
    the region away from its ends (supports and loads sit there); a region too thin for that, or
    several islands with nothing in between, falls back to a point inside the largest island.
    """
    polys = [p for p in getattr(region, "geoms", [region]) if not p.is_empty]
    holes = [shapely.Polygon(r) for p in polys for r in p.interiors]
    if holes:
        hole = max(holes, key=lambda h: h.area)
        hx0, hy0, hx1, hy1 = hole.bounds
        if hx1 - hx0 < 0.8 * ww and hy1 - hy0 < 0.8 * wh:
            return np.asarray(hole.centroid.coords[0])
        ring = hole.exterior
        pts = np.asarray([ring.interpolate(t, normalized=True).coords[0] for t in np.linspace(0, 1, 73)[:-1]])
        inner = np.asarray(hole.buffer(-1e-3).representative_point().coords[0]) if hole.area > 0 else pts[0]
        # sample just inside the material: a point on the ring is on the region's boundary
        out = pts + 0.5 * (pts - inner) / np.maximum(np.hypot(*(pts - inner).T), 1e-9)[:, None]
        inside = shapely.contains_xy(region, out[:, 0], out[:, 1])
        c = _most_stressed(field_, out[inside] if inside.any() else out)
        if c is not None:
            return c
    x0, y0, x1, y1 = region.bounds
    gx, gy = np.meshgrid(np.linspace(x0, x1, 60)[6:-6], np.linspace(y0, y1, 60)[6:-6])
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    pts = pts[shapely.contains_xy(region, pts[:, 0], pts[:, 1])]
    c = _most_stressed(field_, pts)
    if c is not None:
        return c
    biggest = max(polys, key=lambda p: p.area) if polys else region
    return np.asarray(biggest.representative_point().coords[0])
