"""Pictures for ``loadpath compare --report``: the filament orientation field and the strain energy density.

matplotlib is imported inside the drawing functions (optional dependency: ``pip install
loadpath[plots]``) and only its object-oriented API is used (``Figure`` + Agg canvas), so drawing
changes no global state of the caller.  2D predictions are drawn on their triangles; 3D ones by
the tetrahedra cut by the body's mid-height plane.  Each function writes one PNG and returns its path.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from loadpath.errors import ToolMissingError
from loadpath.stiffness.fields import tet_section
from loadpath.stiffness.predict import Prediction

__all__ = ["draw_orientation", "draw_energy", "draw_prediction", "draw_gain"]


def _figure(size: tuple[float, float]):  # type: ignore[no-untyped-def]
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover
        raise ToolMissingError("pictures need matplotlib: pip install 'loadpath[plots]'") from exc
    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig


def _triangles(pred: Prediction) -> tuple[np.ndarray, np.ndarray]:
    """Triangles to draw ``(t, 3, 2)`` and the element each one shows ``(t,)``."""
    mesh = pred.mesh
    if mesh.dim == 2:
        return mesh.points[mesh.cells[:, :3]], np.arange(len(mesh.cells))
    z = mesh.points[:, 2]
    return tet_section(mesh, 0.5 * (float(z.min()) + float(z.max())))


def _size(tri: np.ndarray) -> tuple[float, float]:
    lo, hi = tri.reshape(-1, 2).min(axis=0), tri.reshape(-1, 2).max(axis=0)
    w, h = max(hi[0] - lo[0], 1e-3), max(hi[1] - lo[1], 1e-3)
    scale = 12.0 / max(w, h)
    return max(4.0, w * scale + 2.0), max(3.0, h * scale + 1.5)


def draw_orientation(pred: Prediction, path: str | os.PathLike[str], title: str = "") -> Path:
    """Dominant filament direction per element (short lines), coloured by the fill.

    Line length shows how dominant the direction is (``Prediction.strength``: full length when
    every ply runs one way, a dot for a cross-plied stack).
    """
    from matplotlib.collections import LineCollection, PolyCollection

    tri, elem = _triangles(pred)
    fig = _figure(_size(tri))
    ax = fig.add_subplot(1, 1, 1)
    fill = np.minimum(pred.fill[elem], 1.5)
    pc = PolyCollection(tri, array=fill, cmap="viridis", edgecolor="none")
    pc.set_clim(0.0, 1.2)
    ax.add_collection(pc)
    c = tri.mean(axis=1)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    size = np.sqrt(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / 2.0)
    half = 0.45 * size * pred.strength[elem]
    d = np.column_stack([np.cos(pred.angle[elem]), np.sin(pred.angle[elem])]) * half[:, None]
    ax.add_collection(LineCollection(np.stack([c - d, c + d], axis=1), colors="w", linewidths=0.6))
    fig.colorbar(pc, ax=ax, label="fill (material / element volume)")
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.set_title(title or f"{pred.name}: filament direction (lines) and fill")
    ax.set_xlabel("x, mm")
    ax.set_ylabel("y, mm")
    out = Path(path)
    fig.savefig(out, dpi=130, bbox_inches="tight")
    return out


def draw_energy(pred: Prediction, path: str | os.PathLike[str], title: str = "") -> Path:
    """Strain energy density per element (logarithmic colours), MPa = N mm / mm³."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import LogNorm

    tri, elem = _triangles(pred)
    fig = _figure(_size(tri))
    ax = fig.add_subplot(1, 1, 1)
    w = np.maximum(pred.energy_density[elem], 1e-12)
    hi = float(np.percentile(w, 99.5))
    pc = PolyCollection(tri, array=w, cmap="inferno", edgecolor="none", norm=LogNorm(vmin=hi * 1e-3, vmax=hi))
    ax.add_collection(pc)
    fig.colorbar(pc, ax=ax, label="strain energy density, MPa")
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.set_title(title or f"{pred.name}: strain energy density (compliance {pred.compliance:.4g} N mm)")
    ax.set_xlabel("x, mm")
    ax.set_ylabel("y, mm")
    out = Path(path)
    fig.savefig(out, dpi=130, bbox_inches="tight")
    return out


def draw_prediction(pred: Prediction, folder: str | os.PathLike[str], stem: str) -> list[Path]:
    """Draw both pictures of a prediction into ``folder`` (``<stem>_orientation.png``, ``_energy.png``)."""
    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    return [
        draw_orientation(pred, d / f"{stem}_orientation.png"),
        draw_energy(pred, d / f"{stem}_energy.png"),
    ]


def draw_gain(
    base: Prediction, design: Prediction, index_base: np.ndarray, index_design: np.ndarray,
    path: str | os.PathLike[str], title: str = "",
) -> Path:
    """Where a design gains or loses against a baseline on the same mesh: two panels.

    Left: strain energy density ratio ``design / base`` (below 1: the design deforms less there).
    Right: failure index ratio ``design / base`` (below 1: further from failing there).  Both on a
    logarithmic scale from 1/4 to 4, where both have material.
    """
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import LogNorm

    tri, elem = _triangles(base)
    w, h = _size(tri)
    fig = _figure((w, 2 * h))
    norm = LogNorm(vmin=0.25, vmax=4.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        energy = design.energy_density[elem] / base.energy_density[elem]
        index = index_design[elem] / index_base[elem]
    panels = (("strain energy density", energy), ("failure index", index))
    for i, (what, ratio) in enumerate(panels):
        ax = fig.add_subplot(2, 1, i + 1)
        r = np.where(np.isfinite(ratio) & (ratio > 0), ratio, 1.0)
        pc = PolyCollection(tri, array=np.clip(r, 0.25, 4.0), cmap="coolwarm", edgecolor="none", norm=norm)
        ax.add_collection(pc)
        fig.colorbar(pc, ax=ax, label=f"{what}: {design.name or 'B'} / {base.name or 'A'}")
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_title(title + f" {what} ratio (blue: the second file gains)" if title else f"{what} ratio")
        ax.set_xlabel("x, mm")
        ax.set_ylabel("y, mm")
    out = Path(path)
    fig.savefig(out, dpi=130, bbox_inches="tight")
    return out
