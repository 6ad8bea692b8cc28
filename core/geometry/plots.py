"""Pictures for ``loadpath inspect --png``: a layer's regions, what each selector picked, the stress field.

matplotlib is imported inside the drawing functions (it is an optional dependency: ``pip install
loadpath[plots]``), and only its object-oriented API is used (``Figure`` + Agg canvas), so drawing
changes no global state of the caller's process.  Every function writes one PNG and returns its path.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from loadpath._typing import Region
from loadpath.areal import polygons_of
from loadpath.errors import ToolMissingError
from loadpath.gcode.flavors import Role
from loadpath.gcode.model import Program
from loadpath.geometry.classify import DEFAULT_REPLACE
from loadpath.geometry.model import LayerGeometry

__all__ = ["draw_layer", "draw_selections", "draw_stress"]

_PERIMETER = (Role.PERIMETER, Role.EXTERNAL_PERIMETER, Role.OVERHANG_PERIMETER)
_NOT_PART = (Role.SKIRT, Role.WIPE_TOWER)
_SELECTION_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown", "tab:pink")


def _figure(size: tuple[float, float]) -> Any:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:  # pragma: no cover - matplotlib is in the test and plots extras
        raise ToolMissingError("drawing pictures needs matplotlib: pip install 'loadpath[plots]'") from None
    fig = Figure(figsize=size, dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _size(bounds: tuple[float, float, float, float], width: float = 9.0) -> tuple[float, float]:
    x0, y0, x1, y1 = bounds
    aspect = max(y1 - y0, 1e-3) / max(x1 - x0, 1e-3)
    return width, float(np.clip(width * aspect + 1.2, 3.0, 14.0))


def _region_patch(region: Region, **kw: Any) -> Any:
    """Make a matplotlib PathPatch of a (Multi)Polygon with its holes."""
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MPath

    verts, codes = [], []
    for poly in polygons_of(region):
        for ring in (poly.exterior, *poly.interiors):
            c = np.asarray(ring.coords)[:, :2]
            verts.append(c)
            codes.append(np.r_[MPath.MOVETO, np.full(len(c) - 2, MPath.LINETO), MPath.CLOSEPOLY])
    if not verts:
        return None
    return PathPatch(MPath(np.concatenate(verts), np.concatenate(codes)), **kw)


def _add_region(ax: Any, region: Region, **kw: Any) -> None:
    patch = _region_patch(region, **kw)
    if patch is not None:
        ax.add_patch(patch)


def _segments(m: np.ndarray) -> np.ndarray:
    return np.stack([np.column_stack([m["x0"], m["y0"]]), np.column_stack([m["x1"], m["y1"]])], axis=1)


def _save(fig: Any, path: str | os.PathLike) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.png")
    fig.savefig(tmp)
    tmp.replace(path)
    return path


def draw_layer(path: str | os.PathLike, program: Program, layers: Sequence[LayerGeometry],
               kinds: Sequence[str] = DEFAULT_REPLACE, title: str = "") -> Path:
    """Draw one layer: perimeters, infill lines, part outline, infill domain and replace regions.

    Parameters
    ----------
    path : path-like
        PNG to write.
    program : Program
        The parsed G-code (for the printed lines).
    layers : sequence of LayerGeometry
        The layer of every object to draw (one file layer).
    kinds : sequence of str
        Replaced kinds: their replace regions are filled green, the kept blocks' footprints grey.
    title : str

    Returns
    -------
    Path
    """
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    outlines = [g.outline for g in layers if not g.outline.is_empty]
    bounds = _union_bounds([o.bounds for o in outlines]) if outlines else (0.0, 0.0, 1.0, 1.0)
    fig = _figure(_size(bounds))
    ax = fig.add_subplot(1, 1, 1)
    ax.set_aspect("equal")
    for g in layers:
        for isl in g.islands:
            for b in isl.blocks:
                if b.kind not in kinds and not b.footprint.is_empty:
                    _add_region(ax, b.footprint, facecolor="0.85", edgecolor="none", zorder=1)
            _add_region(ax, isl.replace_region(kinds), facecolor="tab:green", alpha=0.35, edgecolor="none",
                        zorder=2)
    idx = {g.layer_index for g in layers}
    m = program.moves
    sel = m["extrude"] & np.isin(m["layer"], list(idx))
    peri = sel & np.isin(m["role"], _PERIMETER)
    other = sel & ~peri & ~np.isin(m["role"], _NOT_PART)
    ax.add_collection(LineCollection(_segments(m[other]), colors="0.55", linewidths=0.3, zorder=3))
    ax.add_collection(LineCollection(_segments(m[peri]), colors="tab:orange", linewidths=0.6, zorder=4))
    for g in layers:
        for isl in g.islands:
            _add_region(ax, isl.outline, facecolor="none", edgecolor="black", linewidth=1.0, zorder=5)
            _add_region(ax, isl.domain, facecolor="none", edgecolor="tab:blue", linewidth=0.8,
                        linestyle="--", zorder=6)
    pad = 0.03 * max(bounds[2] - bounds[0], bounds[3] - bounds[1]) + 0.5
    ax.set_xlim(bounds[0] - pad, bounds[2] + pad)
    ax.set_ylim(bounds[1] - pad, bounds[3] + pad)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(title, fontsize=9)
    ax.legend(handles=[
        Line2D([], [], color="tab:orange", lw=1, label="perimeters"),
        Line2D([], [], color="0.55", lw=1, label="other extrusions"),
        Line2D([], [], color="black", lw=1, label="part outline"),
        Line2D([], [], color="tab:blue", lw=1, ls="--", label="infill domain"),
        Patch(facecolor="tab:green", alpha=0.35, label=f"replace region ({', '.join(kinds)})"),
        Patch(facecolor="0.85", label="kept infill"),
    ], loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return _save(fig, path)


def _union_bounds(bounds: Sequence[tuple[float, float, float, float]]) -> tuple[float, float, float, float]:
    b = np.asarray(bounds, dtype=float)
    return float(b[:, 0].min()), float(b[:, 1].min()), float(b[:, 2].max()), float(b[:, 3].max())


def draw_selections(path: str | os.PathLike, resolved: Any, title: str = "") -> Path:
    """Draw what each support and load selector picked on one body.

    Parameters
    ----------
    path : path-like
    resolved : loadpath.loadcase.ResolvedBody
    title : str

    Returns
    -------
    Path
    """
    from matplotlib.lines import Line2D

    body = resolved.body
    lo, hi = body.bounds
    fig = _figure(_size((lo[0], lo[1], hi[0], hi[1])))
    ax = fig.add_subplot(1, 1, 1)
    ax.set_aspect("equal")
    for s in body.slabs:
        _add_region(ax, s.outline, facecolor="0.92", edgecolor="0.4", linewidth=0.6, zorder=1)
    handles = []
    pairs = [(s, "support") for s, _ in resolved.supports] + [(ld, "load") for ld, _ in resolved.loads]
    sels = [sel for _, sel in resolved.supports] + [sel for _, sel in resolved.loads]
    for k, ((item, role), sel) in enumerate(zip(pairs, sels, strict=True)):
        colour = _SELECTION_COLOURS[k % len(_SELECTION_COLOURS)]
        lines = sel.lines
        for ln in _line_parts(lines):
            c = np.asarray(ln.coords)
            ax.plot(c[:, 0], c[:, 1], color=colour, lw=3.0, solid_capstyle="butt", zorder=3)
        if resolved.analysis == "3d":  # top / bottom faces carry loads only in 3D
            for _, face in sel.faces:
                _add_region(ax, face, facecolor=colour, alpha=0.3, edgecolor="none", zorder=2)
        what = f"{role} {sel.name!r}: {sel.selector.describe()}"
        if role == "load" and getattr(item, "force", None) is not None:
            f = np.asarray(item.force, dtype=float)
            what += f", F = ({f[0]:g}, {f[1]:g}, {f[2]:g}) N"
            if lines is not None and not lines.is_empty and np.hypot(f[0], f[1]) > 0:
                cx, cy = lines.centroid.x, lines.centroid.y
                span = 0.12 * max(hi[0] - lo[0], hi[1] - lo[1])
                d = f[:2] / np.hypot(f[0], f[1]) * span
                ax.annotate("", xy=(cx + d[0], cy + d[1]), xytext=(cx, cy), annotation_clip=False,
                            arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 2}, zorder=4)
        handles.append(Line2D([], [], color=colour, lw=3, label=what))
    pad = 0.16 * max(hi[0] - lo[0], hi[1] - lo[1]) + 1.0
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad + 0.06 * len(handles) * max(hi[0] - lo[0], hi[1] - lo[1]))
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(title or f"{body.name}: supports and loads ({resolved.analysis})", fontsize=9)
    ax.legend(handles=handles, loc="upper left", fontsize=8, framealpha=0.9)
    return _save(fig, path)


def _line_parts(g: Any) -> list[Any]:
    if g is None or g.is_empty:
        return []
    if hasattr(g, "geoms"):
        out = []
        for p in g.geoms:
            out.extend(_line_parts(p))
        return out
    return [g] if g.geom_type in ("LineString", "LinearRing") else []


def draw_stress(path: str | os.PathLike, field: Any, outline: Region, title: str = "",
                resolution: int = 320, arrows: int = 45) -> Path:
    """Draw a layer's principal stress: magnitude as colour, direction as short line segments.

    Parameters
    ----------
    path : path-like
    field : loadpath.field.StressField
        The layer's field (``Analysis.field(z)``); its followed principal stress is drawn.
    outline : Polygon or MultiPolygon
        The layer's part outline (drawn, and bounds the picture).
    title : str
    resolution : int
        Colour cells along the longer side.
    arrows : int
        Direction segments along the longer side.

    Returns
    -------
    Path
    """
    from matplotlib.collections import LineCollection

    x0, y0, x1, y1 = outline.bounds
    size = max(x1 - x0, y1 - y0)
    h = size / resolution
    xs = np.arange(x0 + h / 2, x1, h)
    ys = np.arange(y0 + h / 2, y1, h)
    gx, gy = np.meshgrid(xs, ys)
    s = field.sample(np.column_stack([gx.ravel(), gy.ravel()]))
    mag = np.where(s.inside, s.magnitude, np.nan).reshape(gx.shape)
    fig = _figure(_size(outline.bounds))
    ax = fig.add_subplot(1, 1, 1)
    ax.set_aspect("equal")
    im = ax.imshow(np.ma.masked_invalid(mag), origin="lower", extent=(x0, x1, y0, y1), cmap="viridis",
                   interpolation="nearest", zorder=1)
    fig.colorbar(im, ax=ax, shrink=0.8, label="|principal stress| (MPa)")
    step = size / arrows
    ax_ = np.arange(x0 + step / 2, x1, step)
    ay_ = np.arange(y0 + step / 2, y1, step)
    px, py = (a.ravel() for a in np.meshgrid(ax_, ay_))
    d = field.sample(np.column_stack([px, py]))
    ok = d.valid
    half = 0.4 * step * d.direction[ok]
    p = np.column_stack([px[ok], py[ok]])
    segs = np.stack([p - half, p + half], axis=1)
    ax.add_collection(LineCollection(segs, colors="white", linewidths=0.9, zorder=3))
    _add_region(ax, outline, facecolor="none", edgecolor="black", linewidth=0.8, zorder=4)
    pad = 0.02 * size + 0.5
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(title, fontsize=9)
    return _save(fig, path)
