"""Pictures of a stress field and of what each selector picked (matplotlib, imported when called).

``loadpath inspect --loadcase CASE.toml --png DIR`` uses these: :func:`draw_field` shows the followed
principal stress of a layer (magnitude as colour, direction as short segments), :func:`draw_selectors`
the part outline with the supports (blue) and loads (red) the selectors picked; :func:`save_png`
writes a figure with both side by side.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from loadpath.field import StressField
from loadpath.loadcase.resolve import ResolvedBody
from shapely.geometry.base import BaseGeometry

__all__ = ["draw_field", "draw_selectors", "save_png"]


def _outline(ax: Any, region: BaseGeometry, **kw: Any) -> None:
    for poly in getattr(region, "geoms", [region]):
        for ring in [poly.exterior, *poly.interiors]:
            x, y = np.asarray(ring.coords).T[:2]
            ax.plot(x, y, **kw)


def _lines(ax: Any, g: BaseGeometry | None, **kw: Any) -> None:
    if g is None or g.is_empty:
        return
    for ln in getattr(g, "geoms", [g]):
        x, y = np.asarray(ln.coords).T[:2]
        ax.plot(x, y, **kw)
        kw.pop("label", None)


def draw_field(
    ax: Any,
    field: StressField,
    region: BaseGeometry | None = None,
    pixels: int = 400,
    segments: int = 40,
    cmap: str = "viridis",
) -> Any:
    """Draw a stress field: ``|s|`` as colour, the followed principal direction as short segments.

    Parameters
    ----------
    ax : matplotlib Axes
    field : StressField
    region : shapely geometry, optional
        Where to draw (its bounding box is sampled); default ``field.region``.
    pixels : int
        Samples along the longer side for the colour image.
    segments : int
        Segments along the longer side; invalid (undefined direction) points get none.
    cmap : str

    Returns
    -------
    matplotlib image
        For a colour bar.
    """
    region = region if region is not None else getattr(field, "region", None)
    if region is None:
        raise ValueError("draw_field needs a region (the field has none)")
    x0, y0, x1, y1 = region.bounds
    span = max(x1 - x0, y1 - y0)
    nx = max(2, int(pixels * (x1 - x0) / span))
    ny = max(2, int(pixels * (y1 - y0) / span))
    gx, gy = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
    s = field.sample(np.column_stack([gx.ravel(), gy.ravel()]))
    mag = np.ma.masked_invalid(s.magnitude.reshape(ny, nx))
    im = ax.imshow(mag, origin="lower", extent=(x0, x1, y0, y1), cmap=cmap, interpolation="nearest")
    step = span / segments
    sx, sy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    q = field.sample(np.column_stack([sx.ravel(), sy.ravel()]))
    ok = q.valid
    if np.any(ok):
        from matplotlib.collections import LineCollection

        c = np.column_stack([sx.ravel(), sy.ravel()])[ok]
        d = q.direction[ok] * (0.4 * step)
        ax.add_collection(LineCollection(np.stack([c - d, c + d], axis=1), colors="white", linewidths=0.8))
    _outline(ax, region, color="black", linewidth=0.6)
    ax.set_aspect("equal")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    return im


def draw_selectors(ax: Any, resolved: ResolvedBody, z: float | None = None) -> None:
    """Draw the part outline and the boundary each support (blue) and load (red) picked.

    Parameters
    ----------
    ax : matplotlib Axes
    resolved : ResolvedBody
    z : float, mm, optional
        Layer height; default the middle of the body (the outline and side-wall picks there).
    """
    body = resolved.body
    z0, z1 = body.z_range
    zq = 0.5 * (z0 + z1) if z is None else z
    slab = body.slab_at(zq) or body.slabs[0]
    _outline(ax, slab.outline, color="0.5", linewidth=0.8)
    for color, items in (("tab:blue", resolved.supports), ("tab:red", resolved.loads)):
        for item, sel in items:
            g = sel.lines_at(zq)
            if g is None and sel.faces:  # top / bottom faces only: draw their outline dashed
                for _, face in sel.faces:
                    _outline(ax, face, color=color, linewidth=1.5, linestyle="--")
                ax.plot([], [], color=color, linestyle="--", label=item.name)
                continue
            _lines(ax, g, color=color, linewidth=2.5, label=item.name)
            force = getattr(item, "force", None)
            if g is not None and force is not None and np.hypot(force[0], force[1]) > 0:
                c = g.centroid
                lo, hi = body.bounds
                scale = 0.08 * float(np.max(hi[:2] - lo[:2])) / np.hypot(force[0], force[1])
                ax.annotate(
                    "",
                    xy=(c.x + force[0] * scale, c.y + force[1] * scale),
                    xytext=(c.x, c.y),
                    arrowprops={"arrowstyle": "->", "color": color, "linewidth": 1.5},
                )
    ax.set_aspect("equal")
    ax.margins(0.1)
    ax.legend(loc="upper right", fontsize="small")
    ax.set_title(f"{resolved.name}: {resolved.analysis.upper()} ({resolved.reason})", fontsize="small")


def save_png(
    path: str | Path, field: StressField, resolved: ResolvedBody, z: float | None = None, title: str = ""
) -> Path:
    """Write a PNG with the selections (left) and the stress field (right).

    Returns
    -------
    Path
        The file written (through a temporary file, renamed).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    path = Path(path)
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    try:
        draw_selectors(a, resolved, z)
        im = draw_field(b, field)
        fig.colorbar(im, ax=b, label=f"|s| ({field.principal}), MPa", shrink=0.8)
        b.set_title(title or f"principal stress, scale {field.scale:.3g} MPa", fontsize="small")
        tmp = path.with_name(path.name + ".tmp")
        fig.savefig(tmp, dpi=110, format="png")
        tmp.replace(path)
    finally:
        plt.close(fig)
    return path
