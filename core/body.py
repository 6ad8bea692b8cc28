"""A body: one object of the print as a stack of slabs (z range + part outline).

The layer geometry gives, per layer, the **part outline** (shapely Polygon/MultiPolygon with holes)
and the layer's z range. :func:`merge_slabs` turns consecutive layers whose outlines agree into one
prism, so a 100-layer part becomes a handful of prisms; a body with one prism is solved in 2D.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Region
from loadpath.areal import polygons_of
from loadpath.errors import GeometryError
from loadpath.tolerances import TOL
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.polygon import orient

__all__ = ["Slab", "Body", "merge_slabs", "cover_slabs", "outline_difference"]


def _clean(region: Region, where: str) -> Region:
    if not isinstance(region, (Polygon, MultiPolygon)):
        raise GeometryError(
            f"{where}: the part outline must be a shapely Polygon or MultiPolygon, "
            f"got {type(region).__name__}"
        )
    if region.is_empty or region.area <= 0:
        raise GeometryError(f"{where}: the part outline is empty; check the layer's perimeters")
    if not region.is_valid:
        fixed = shapely.make_valid(region)
        polys = [g for g in getattr(fixed, "geoms", [fixed]) if isinstance(g, (Polygon, MultiPolygon))]
        region = shapely.unary_union(polys)
        if region.is_empty:
            raise GeometryError(f"{where}: the part outline is not a valid polygon and cannot be repaired")
    polys = [orient(p, sign=1.0) for p in polygons_of(region)]
    return polys[0] if len(polys) == 1 else MultiPolygon(polys)


@dataclass(frozen=True)
class Slab:
    """A prism: the part outline extruded from ``z0`` to ``z1``.

    Attributes
    ----------
    z0, z1 : float, mm
        Bottom and top, ``z1 > z0``.
    outline : shapely Polygon or MultiPolygon, mm
        The part outline (outer rings counter-clockwise, holes clockwise).
    """

    z0: float
    z1: float
    outline: Region

    def __post_init__(self) -> None:
        if not (np.isfinite(self.z0) and np.isfinite(self.z1) and self.z1 > self.z0):
            raise GeometryError(f"slab z range {self.z0}..{self.z1} mm is empty; z1 must be above z0")
        object.__setattr__(self, "outline", _clean(self.outline, f"slab z {self.z0}..{self.z1}"))

    @property
    def thickness(self) -> float:
        """``z1 - z0``, mm."""
        return self.z1 - self.z0


@dataclass(frozen=True)
class Body:
    """One object, solved on its own: a stack of contiguous slabs, bottom first.

    Attributes
    ----------
    name : str
        The object name (PrusaSlicer ``; printing object``, Cura ``;MESH:``).
    slabs : tuple of Slab
    """

    name: str
    slabs: tuple[Slab, ...]

    def __post_init__(self) -> None:
        slabs = tuple(self.slabs)
        if not slabs:
            raise GeometryError(f"object {self.name!r} has no layers")
        for a, b in zip(slabs[:-1], slabs[1:], strict=True):
            if abs(b.z0 - a.z1) > 1e3 * TOL.length_mm:
                raise GeometryError(
                    f"object {self.name!r}: layers are not contiguous (one ends at z = {a.z1}, "
                    "the next starts at "
                    f"z = {b.z0}); give consecutive z ranges"
                )
        object.__setattr__(self, "slabs", slabs)

    @classmethod
    def from_layers(cls, name: str, layers: Iterable[tuple[float, float, Region]]) -> Body:
        """Build a body from ``(z_bottom, z_top, outline)`` per layer (not merged)."""
        return cls(name, tuple(Slab(float(a), float(b), o) for a, b, o in layers))

    @property
    def z_range(self) -> tuple[float, float]:
        """Bottom and top of the body, mm."""
        return self.slabs[0].z0, self.slabs[-1].z1

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounding box ``(lower (3,), upper (3,))``, mm."""
        b = np.array([s.outline.bounds for s in self.slabs])
        lo = np.array([b[:, 0].min(), b[:, 1].min(), self.slabs[0].z0])
        hi = np.array([b[:, 2].max(), b[:, 3].max(), self.slabs[-1].z1])
        return lo, hi

    def describe_bounds(self) -> str:
        """``x a..b, y c..d, z e..f`` for messages."""
        lo, hi = self.bounds
        return ", ".join(f"{a} {lo[i]:.3f}..{hi[i]:.3f}" for i, a in enumerate("xyz"))

    def slab_at(self, z: float) -> Slab | None:
        """Return the slab containing height ``z`` (the lower one on a shared face), or None."""
        for s in self.slabs:
            if s.z0 - TOL.length_mm <= z <= s.z1 + TOL.length_mm:
                return s
        return None


def outline_difference(a: Region, b: Region) -> float:
    """Mean distance between two outlines: ``area(a xor b) / perimeter(a)``, mm."""
    per = max(a.length, TOL.length_mm)
    return float(shapely.symmetric_difference(a, b).area / per)


def merge_slabs(
    body: Body,
    tol: float = TOL.region_compare_mm,
    min_thickness: float = 0.6,
    absorb: float = 0.5,
) -> Body:
    """Merge consecutive layers whose outlines agree into prisms.

    1. Runs: a layer joins the current run when :func:`outline_difference` from the run's first layer
       is below ``tol``.
    2. Thin runs (thinner than ``min_thickness``, e.g. a first layer shrunk by the slicer's
       elephant-foot compensation) join the neighbouring run whose outline is closest, when it
       differs by less than ``absorb``.
    3. Each run becomes one slab with the outline of its middle layer.

    Parameters
    ----------
    body : Body
        One slab per layer.
    tol : float, mm
    min_thickness : float, mm
    absorb : float, mm

    Returns
    -------
    Body
        Same name, fewer slabs; shared faces stay at the original layer heights.
    """
    slabs = body.slabs
    groups: list[list[Slab]] = [[slabs[0]]]
    for s in slabs[1:]:
        if outline_difference(groups[-1][0].outline, s.outline) <= tol:
            groups[-1].append(s)
        else:
            groups.append([s])
    runs = [_Run(g[0].z0, g[-1].z1, g[len(g) // 2].outline) for g in groups]
    runs = _absorb_thin(runs, min_thickness, absorb)
    return dataclasses.replace(body, slabs=tuple(Slab(r.z0, r.z1, r.outline) for r in runs))


@dataclass
class _Run:
    z0: float
    z1: float
    outline: Region


def _absorb_thin(runs: list[_Run], min_thickness: float, absorb: float) -> list[_Run]:
    """Merge runs thinner than ``min_thickness`` into the closest neighbour (which keeps its outline)."""
    runs = list(runs)
    while len(runs) > 1:
        for i, run in enumerate(runs):
            if run.z1 - run.z0 >= min_thickness:
                continue
            best: tuple[float, int] | None = None
            for j in (i - 1, i + 1):
                if 0 <= j < len(runs):
                    d = outline_difference(runs[j].outline, run.outline)
                    if d < absorb and (best is None or d < best[0]):
                        best = (d, j)
            if best is not None:
                j = best[1]
                runs[j] = _Run(min(run.z0, runs[j].z0), max(run.z1, runs[j].z1), runs[j].outline)
                del runs[i]
                break
        else:
            break
    return runs


def cover_slabs(body: Body, tol: float, grid: float | None = None) -> Body:
    """Coarser prisms for a 3D mesh: neighbouring slabs within ``tol`` of each other become one.

    A part whose outline drifts a little every layer (twist, taper, ramp) has as many slabs as
    layers, and a conforming mesh that follows every outline needs elements as small as that drift.
    Here consecutive slabs join a group while the Hausdorff distance of their outline from the
    group's first one is at most ``tol`` (a mesh of element size ``h`` resolves no finer detail
    anyway: ``tol`` of about ``h / 2``), and each group gets an outline covering every layer in it:

    * the union of the group's outlines, so every layer's infill lies inside the mesh and its field
      is defined everywhere the engines sample it;
    * with the notches narrower than ``tol`` that the union leaves where outlines drift (the steps
      between rotated corners) filled (a morphological closing of radius ``tol / 2``, applied only
      near the parts that differ between the layers, so real slots of the part stay open);
    * snapped to a grid of ``grid`` mm (snap rounding), so two outlines that nearly touch either
      share a vertex or stay a grid step apart: no near-coincident lines, no sliver elements.

    A slab whose outline does not drift (a prismatic part, the steps of a stepped part) is returned
    unchanged, apart from the grid.

    Parameters
    ----------
    body : Body
        Merged slabs (:func:`merge_slabs`).
    tol : float, mm
        Largest distance between the outlines of one group; 0 keeps every slab.
    grid : float, mm, optional
        Snapping grid; default none.

    Returns
    -------
    Body
        Same name and z range, at most as many slabs.
    """
    groups: list[list[Slab]] = [[body.slabs[0]]]
    for s in body.slabs[1:]:
        first = groups[-1][0]
        if tol > 0 and shapely.hausdorff_distance(first.outline, s.outline) <= tol:
            groups[-1].append(s)
        else:
            groups.append([s])
    slabs = []
    for g in groups:
        outlines = [s.outline for s in g]
        region = outlines[0]
        if len(g) > 1:
            region = shapely.union_all(outlines)
            common = shapely.intersection_all(outlines)
            drift = shapely.difference(region, common)
            if not drift.is_empty:
                r = 0.5 * tol
                closed = region.buffer(r, join_style="mitre").buffer(-r, join_style="mitre")
                fill = shapely.intersection(closed, drift.buffer(r))
                region = shapely.union(region, fill)
        if grid:
            region = shapely.set_precision(region, grid)
        polys = [p for p in getattr(region, "geoms", [region]) if isinstance(p, Polygon) and p.area > 0]
        if not polys:  # snapped away: keep the group's first outline
            polys = polygons_of(g[0].outline)
        slabs.append(Slab(g[0].z0, g[-1].z1, polys[0] if len(polys) == 1 else MultiPolygon(polys)))
    return dataclasses.replace(body, slabs=tuple(slabs))
