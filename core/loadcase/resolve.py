"""Resolve a load case on the bodies of a print: which body, which boundary, 2D or 3D.

:func:`resolve` is the step between the validated :class:`~loadpath.loadcase.model.LoadCase` and
the finite-element analysis: it picks the bodies the load case applies to, merges their layers into
prisms, evaluates every selector on each body's boundary (an empty selection is an error naming
the selector and the part's bounding box), and decides whether the 2D plane-stress shortcut is
exact enough (one prism and an in-plane load case) or a 3D analysis is needed.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
import shapely
from loadpath.body import Body, merge_slabs
from loadpath.errors import LoadCaseError
from loadpath.loadcase.model import HoleSelector, Load, LoadCase, Support
from loadpath.loadcase.select import Selection, nearest_hole, select
from loadpath.tolerances import TOL
from shapely.geometry.base import BaseGeometry

__all__ = ["ResolvedBody", "resolve", "resolve_body", "empty_selections"]


@dataclass(frozen=True)
class ResolvedBody:
    """A load case applied to one body.

    Attributes
    ----------
    body : Body
        Merged into prisms.
    loadcase : LoadCase
    supports : tuple of (Support, Selection)
    loads : tuple of (Load, Selection)
    analysis : {"2d", "3d"}
        ``"2d"``: plane stress over the body's thickness (one prism, in-plane load case).
    reason : str
        Why this analysis was chosen (for reports).
    layers : Body, optional
        The body as given, before merging (one slab per layer): what a 3D mesh must cover
        (:func:`~loadpath.body.cover_slabs`).
    origin : (3,) float, mm, optional
        Origin of the selector coordinates (the body's minimum corner for ``frame = "part"``).
    """

    body: Body
    loadcase: LoadCase
    supports: tuple[tuple[Support, Selection], ...]
    loads: tuple[tuple[Load, Selection], ...]
    analysis: str
    reason: str
    layers: Body | None = field(default=None, compare=False)
    origin: np.ndarray | None = field(default=None, compare=False)

    @property
    def name(self) -> str:
        """The body's name."""
        return self.body.name

    @property
    def thickness(self) -> float:
        """Height of the body, mm (the plate thickness of a 2D analysis)."""
        z0, z1 = self.body.z_range
        return z1 - z0

    @property
    def selections(self) -> tuple[Selection, ...]:
        """All selections, supports first."""
        return tuple(s for _, s in self.supports) + tuple(s for _, s in self.loads)

    def load_entry(self, z: float | None = None) -> BaseGeometry | None:
        """Where the load enters: the side-wall lines the load selectors picked at height ``z``.

        Parameters
        ----------
        z : float, mm, optional
            Layer height; None: all heights.

        Returns
        -------
        shapely (Multi)LineString or None
        """
        parts = []
        for _, sel in self.loads:
            g = sel.lines if z is None else sel.lines_at(z)
            if g is not None and not g.is_empty:
                parts.append(g)
        if not parts:
            return None
        return shapely.line_merge(shapely.unary_union(parts))

    def held_loads(self, least: float = 0.02) -> list[str]:
        """Warnings for loads that act where a support holds the part, one line each.

        A load's force on the supported nodes goes straight into the support and never loads the
        part: all of it fails the solve ("the load vector is zero"), a share of it was lost
        silently (a load within 20 mm of an edge a support holds within 10 mm: 60 % of its edge).
        Counted on the picked side-wall lines (xy); ``least``: the share below which nothing is said.
        """
        out = []
        eps = max(10.0 * TOL.length_mm, 1e-6)
        for ld, lsel in self.loads:
            lines = lsel.lines
            if lines is None or lines.is_empty or lines.length <= 0:
                continue
            for sp, ssel in self.supports:
                held = ssel.lines
                if held is None or held.is_empty:
                    continue
                share = float(lines.intersection(held.buffer(eps)).length / lines.length)
                if share >= least:
                    out.append(
                        f"object {self.name!r}: load {ld.name!r} acts where support {sp.name!r} holds the "
                        f"part on {share:.0%} of its edge, and that share of its force goes straight into "
                        "the support; move the two selectors apart"
                    )
        return out

    def refine_lines(self) -> list[BaseGeometry]:
        """Return the picked side-wall lines (xy), where the mesh is refined."""
        return [g for s in self.selections if (g := s.lines) is not None]

    def split_points(self) -> np.ndarray:
        """Return the ends of the picked side-wall pieces, ``(n, 2)`` mm: vertices the mesh must have."""
        pts = []
        for s in self.selections:
            if s.lower is None:
                continue
            for _, _, g in s.lateral:
                for ln in getattr(g, "geoms", [g]):
                    c = np.asarray(ln.coords)
                    if len(c) >= 2 and not np.allclose(c[0], c[-1]):
                        pts.extend([c[0, :2], c[-1, :2]])
        return np.array(pts, dtype=float).reshape(-1, 2)

    def cut_boxes(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Boxes of side/box selectors clipped to a little more than the body, for conforming 3D meshes."""
        lo_b, hi_b = self.body.bounds
        pad = 0.01 * float(np.max(hi_b - lo_b)) + 1.0
        out = []
        for s in self.selections:
            if s.lower is None:
                continue
            lo = np.maximum(s.lower, lo_b - pad)
            hi = np.minimum(s.upper, hi_b + pad)
            if np.all(hi > lo):
                out.append((lo, hi))
        return out


def resolve(
    loadcase: LoadCase, bodies: Iterable[Body], analysis: str | None = None
) -> tuple[ResolvedBody, ...]:
    """Apply a load case to the bodies of a print.

    Parameters
    ----------
    loadcase : LoadCase
    bodies : iterable of Body
        One per object, one slab per layer (or already merged).
    analysis : {"2d", "3d"}, optional
        Force an analysis; default: 2D when the body is one prism and the load case is in-plane.

    Returns
    -------
    tuple of ResolvedBody
        The body named by ``object =``, or every body (each must be held by its own supports).

    Raises
    ------
    LoadCaseError
        Unknown object; a selector that selects nothing (naming it and the bounding box).
    """
    bodies = list(bodies)
    if loadcase.object is not None:
        chosen = [b for b in bodies if b.name == loadcase.object]
        if not chosen:
            names = ", ".join(repr(b.name) for b in bodies) or "none"
            raise LoadCaseError(
                f"{loadcase.source}: object = {loadcase.object!r} is not in the G-code "
                f"(objects found: {names}); "
                "fix the name or remove the key"
            )
        bodies = chosen
    if not bodies:
        raise LoadCaseError(f"{loadcase.source}: there is no object to apply the load case to")
    return tuple(resolve_body(loadcase, b, analysis) for b in bodies)


def resolve_body(
    loadcase: LoadCase,
    body: Body,
    analysis: str | None = None,
    origin: np.ndarray | None = None,
    check: bool = True,
) -> ResolvedBody:
    """Apply a load case to one body (see :func:`resolve`).

    ``origin`` overrides the frame's origin (a coarser stack for the mesh keeps the selectors where
    the part's own frame put them).  ``check = False`` returns selections that pick nothing instead
    of raising (the load-case editor lists every one with :func:`empty_selections`).
    """
    merged = merge_slabs(body)
    if origin is None:
        origin = merged.bounds[0] if loadcase.frame == "part" else np.zeros(3)
    origin = np.asarray(origin, dtype=float)
    sups = tuple((s, select(s.where, merged, origin, s.name, "support")) for s in loadcase.supports)
    loads = tuple((ld, select(ld.where, merged, origin, ld.name, "load")) for ld in loadcase.loads)
    sels = [s for _, s in sups] + [s for _, s in loads]
    if analysis is not None:
        if analysis not in ("2d", "3d"):
            raise ValueError(f"analysis must be '2d' or '3d', not {analysis!r}")
        kind, reason = analysis, "requested"
    elif len(merged.slabs) > 1:
        kind, reason = "3d", f"the part has {len(merged.slabs)} distinct regions over its height"
    elif loadcase.needs_3d:
        kind, reason = "3d", "the load case has loads, supports or selectors in z"
    elif any(s.measure("2d") <= _tiny(merged) < s.measure("3d") for s in sels):
        kind, reason = "3d", "a selector picks only top or bottom faces"
    else:
        kind, reason = "2d", "one region over the height and an in-plane load case: plane stress"
    rb = ResolvedBody(merged, loadcase, sups, loads, kind, reason, layers=body, origin=origin)
    if check:
        empty = empty_selections(rb)
        if empty:
            raise LoadCaseError(empty[0][1])
    return rb


def empty_selections(rb: ResolvedBody) -> list[tuple[Selection, str]]:
    """Return the selections of a resolved body that pick nothing, each with the error ``run`` gives.

    A pick as thin as the selectors' tolerance counts as nothing.
    """
    return [
        (sel, _empty_message(rb.loadcase, rb.body, sel))
        for sel in rb.selections
        if sel.measure(rb.analysis) <= _tiny(rb.body)
    ]


def _tiny(body: Body) -> float:
    lo, hi = body.bounds
    return 1e-6 * float(np.sum((hi - lo) ** 2))


def _empty_message(lc: LoadCase, body: Body, sel: Selection) -> str:
    what = f"{sel.role} {sel.name!r} ({sel.selector.describe()})"
    extra = ""
    if isinstance(sel.selector, HoleSelector):
        origin = body.bounds[0] if lc.frame == "part" else np.zeros(3)
        p = (sel.selector.near[0] + origin[0], sel.selector.near[1] + origin[1])
        best = math.inf
        for s in body.slabs:
            _, d = nearest_hole(s.outline, p)
            best = min(best, d)
        extra = "; the part has no holes" if math.isinf(best) else f"; the nearest hole is {best:.3f} mm away"
    frame = (
        ' (selector coordinates are relative to its minimum corner: frame = "part")'
        if lc.frame == "part"
        else _frame_hint(sel.selector, body)
    )
    return (
        f"{lc.source}: {what} selects no boundary of object {body.name!r}{extra}; "
        f"part bounding box is {body.describe_bounds()}{frame}"
    )


def _frame_hint(selector, body: Body) -> str:
    """A hint to use ``frame = "part"`` when bed coordinates miss the part by more than its size.

    Selector coordinates measured from the part's own corner (a CAD drawing) land near the bed's
    origin, far from a part the slicer placed mid-bed.
    """
    lo, hi = (np.asarray(b, dtype=float) for b in body.bounds)
    if isinstance(selector, HoleSelector):
        a = b = np.array([selector.near[0], selector.near[1], 0.5 * (lo[2] + hi[2])])
    elif hasattr(selector, "lower") and hasattr(selector, "upper"):
        a, b = np.asarray(selector.lower, dtype=float), np.asarray(selector.upper, dtype=float)
    else:
        return ""
    with np.errstate(invalid="ignore"):
        gap = np.maximum(0.0, np.maximum(a - hi, lo - b))
    gap = np.where(np.isfinite(gap), gap, 0.0)
    miss, size = float(np.hypot(*gap[:2])), float(np.max(hi[:2] - lo[:2]))
    if miss <= size:
        return ""
    return (
        f"; the selector is {miss:.0f} mm off a part {size:.0f} mm across: if its coordinates are "
        'measured from the part\'s own corner, put frame = "part" at the top of the load case'
    )
