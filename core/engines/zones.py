"""A spatially varying pitch laid by zones: the density field made piecewise constant.

:func:`zones` splits a replace region where the pitch of a :class:`loadpath.density.DensityField`,
rounded to a few levels, changes; :func:`loadpath.engines.generate` fills each zone with the engine
at the zone's pitch, so inside a zone the engines' own spacing terms (the swarm's QP box and spacing,
the streamlines' seeding distance and minimum spacing) use that pitch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Points2, Region
from loadpath.areal import as_region
from loadpath.density import DensityField

__all__ = ["Zone", "zones"]


@dataclass(frozen=True)
class Zone:
    """Part of a region filled at one pitch.

    Attributes
    ----------
    region : Polygon or MultiPolygon, mm
    pitch : float, mm
        The zone's pitch for a field at its own mean fill (scale with the run's nominal pitch over
        :attr:`DensityField.base_pitch`).
    """

    region: Region
    pitch: float


def _cells(mask: np.ndarray, origin: np.ndarray, cell: float) -> Region:
    """Union of the grid cells in ``mask`` (rows merged into runs first)."""
    boxes = []
    for j in np.flatnonzero(mask.any(axis=1)):
        row = np.r_[False, mask[j], False].astype(np.int8)
        d = np.diff(row)
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        y0 = origin[1] + (j - 0.5) * cell
        for a, b in zip(starts, ends, strict=True):
            xa, xb = origin[0] + (a - 0.5) * cell, origin[0] + (b - 0.5) * cell
            boxes.append(shapely.box(xa, y0, xb, y0 + cell))
    return shapely.union_all(boxes) if boxes else shapely.Polygon()


def zones(df: DensityField, region: Region, n_levels: int = 6) -> list[Zone]:
    """Split a region into zones of one pitch each: the density field made piecewise constant.

    The pitch field is rounded to ``n_levels`` pitches spaced evenly in ``log(pitch)``
    (:meth:`DensityField.levels`); each level's pitch is then chosen so the zone lays the fill the
    field asks for on average over the zone (``flow_width / mean(rho)``), so the total plastic stays
    the field's.  Cells are labelled by the nearest level after a modal filter over about two
    slicer pitches (no zone narrower than a few lines), and zone pieces smaller than four of their
    own pitches squared join the neighbour they share most boundary with.

    Returns
    -------
    list of Zone
        Disjoint, covering ``region``; one zone when the field is uniform.
    """
    levels = df.levels(n_levels)
    if len(levels) == 1:
        return [Zone(region, float(levels[0]))]
    inside = np.isfinite(df.rho)
    logp = np.log(np.where(inside, df.pitch, 1.0))
    lab = np.argmin(np.abs(logp[..., None] - np.log(levels)[None, None, :]), axis=2)
    lab = np.where(inside, lab, -1)
    from scipy.ndimage import uniform_filter

    size = min(9, int(max(3, 2 * round(np.median(levels) / df.cell) + 1)))
    votes = np.stack(
        [uniform_filter((lab == k).astype(float), size, mode="constant") for k in range(len(levels))]
    )
    lab = np.where(inside, np.argmax(votes, axis=0), -1)
    lab = np.where(inside & (lab < 0), 0, lab).astype(int)
    # each piece of each level, as polygons clipped to the region
    pieces: list[tuple[Region, int]] = []
    for k in range(len(levels)):
        m = lab == k
        if not m.any():
            continue
        g = _cells(m, df.origin, df.cell)
        for p in shapely.get_parts(g):
            pieces.append((p, k))
    # the cells' union does not follow the region's edge: the zones are the region split along the
    # cell boundaries between levels (each piece grown over the region's edge, then clipped)
    reach = 2.0 * df.cell
    geoms = [as_region(shapely.intersection(region, p.buffer(reach, join_style="mitre"))) for p, _ in pieces]
    claimed = shapely.Polygon()
    order = np.argsort([-g.area for g in geoms])
    taken: list[tuple[Region, int]] = []
    for i in order:
        g = as_region(shapely.difference(geoms[i], claimed)) if not claimed.is_empty else geoms[i]
        claimed = shapely.union(claimed, g)
        taken.append((g, pieces[i][1]))
    rest = as_region(shapely.difference(region, claimed))
    # merge small pieces into the neighbour they share most boundary with
    items = [(g, k) for g, k in taken if not g.is_empty]
    changed = True
    while changed and len(items) > 1:
        changed = False
        for a, (g, k) in enumerate(items):
            if g.area >= 4.0 * float(levels[k]) ** 2:
                continue
            best, share = -1, 0.0
            for b, (h, _) in enumerate(items):
                if b == a:
                    continue
                s = shapely.intersection(g.buffer(1e-6), h.boundary).length
                if s > share:
                    best, share = b, s
            if best < 0:
                continue
            h, kb = items[best]
            items[best] = (as_region(shapely.union(h, g)), kb)
            items.pop(a)
            changed = True
            break
    if not rest.is_empty and items:
        g, k = max(items, key=lambda t: t[0].area)
        items[items.index((g, k))] = (as_region(shapely.union(g, rest)), k)
    # one zone per level; its pitch lays the fill the field asks for on average over it
    out: list[Zone] = []
    for k in sorted({k for _, k in items}):
        geom = shapely.union_all([g for g, kk in items if kk == k])
        geom = shapely.make_valid(geom) if not geom.is_valid else geom
        polys = [p for p in shapely.get_parts(geom) if p.geom_type == "Polygon" and p.area > 0]
        if not polys:
            continue
        geom = shapely.MultiPolygon(polys) if len(polys) > 1 else polys[0]
        r = df.sample(_grid_points(geom, df.cell))
        out.append(Zone(geom, float(df.flow_width / np.mean(r)) if len(r) else float(levels[k])))
    return out


def _grid_points(geom: Region, cell: float) -> Points2:
    x0, y0, x1, y1 = geom.bounds
    gx, gy = np.meshgrid(np.arange(x0 + 0.5 * cell, x1, cell), np.arange(y0 + 0.5 * cell, y1, cell))
    ok = shapely.contains_xy(geom, gx, gy)
    if not ok.any():
        c = geom.representative_point()
        return np.array([[c.x, c.y]])
    return np.column_stack([gx[ok], gy[ok]])
