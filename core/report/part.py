"""The report's part view: the load case drawn on the part, and where the part gained or lost.

:func:`part_figure` draws one body seen from above: its outline, the supports (blue edges) and the
loads (red edges with an arrow along the force) the load case selected, and, when the verdict's
stiffness prediction is there, the mesh coloured by how much less (green) or more (purple) strain
energy each element stores with loadpath's paths than with the slicer's for the same load (the
stiffness model's :attr:`loadpath.stiffness.change.BodyChange.energy_ratio`; the failure-index
ratio joins it when the mechanics model gives one).  3D bodies are drawn by their element centroids.
"""

from __future__ import annotations

import numpy as np
import shapely
from loadpath.report.svg import Canvas

__all__ = ["part_figure", "ratio_colour"]

_GAIN, _LOSS, _EVEN = np.array([26, 150, 65]), np.array([123, 50, 148]), np.array([235, 235, 235])


def ratio_colour(ratio: np.ndarray) -> list[str]:
    """Colours of energy ratios (after / before): green below 1 (works less: stiffer), purple above.

    Saturated at a factor 2 either way (``log2`` in [-1, 1]); NaN (unstrained) is white.
    """
    r = np.asarray(ratio, dtype=float)
    t = np.clip(np.log2(np.where(r > 0, r, np.nan)), -1.0, 1.0)
    out = []
    for v in t:
        if not np.isfinite(v):
            out.append("#ffffff")
            continue
        end = _GAIN if v < 0 else _LOSS
        c = _EVEN + abs(v) * (end - _EVEN)
        out.append("#{:02x}{:02x}{:02x}".format(*(int(round(x)) for x in c)))
    return out


def _outline(rb):
    return shapely.union_all([s.outline for s in rb.body.slabs])


def part_figure(rb, body_change=None, width: int = 960) -> str:
    """SVG of one body with its load case and, if given, its energy-ratio map.

    Parameters
    ----------
    rb : ResolvedBody
    body_change : BodyChange, optional
        The stiffness prediction of this body (:mod:`loadpath.stiffness.change`).
    """
    outline = _outline(rb)
    x0, y0, x1, y1 = outline.bounds
    pad = 0.08 * max(x1 - x0, y1 - y0)
    cv = Canvas((x0 - pad, y0 - pad, x1 + pad, y1 + pad), width=width)
    cv.region(outline, fill="#f7f7f7", stroke="#666666")
    legend = "the load case: supports blue, loads red (arrow: the force's direction)"
    if body_change is not None:
        mesh = body_change.mesh
        pts = np.asarray(mesh.points)[:, :2]
        cells = np.asarray(mesh.cells)
        colours = ratio_colour(body_change.energy_ratio)
        if getattr(mesh, "dim", pts.shape[1]) == 2:  # triangles (their corners; mid-side nodes follow)
            for tri, col in zip(cells[:, :3], colours, strict=True):
                cv.items.append(f'<path d="{cv._d(pts[tri], True)}" fill="{col}" stroke="none"/>')
        else:  # tetrahedra: a dot per element, seen from above
            cen = pts[cells].mean(axis=1)
            q = cv.xy(cen)
            r = max(1.5, 0.5 * cv.s * (x1 - x0) / max(np.sqrt(len(cells)), 1.0))
            cv.items.extend(
                f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:.1f}" fill="{c}"/>'
                for (x, y), c in zip(q, colours, strict=True)
            )
        cv.region(outline, fill="none", stroke="#666666")
        legend = (
            "strain energy with loadpath's paths over the slicer's, same load (green: works less, i.e. "
            "stiffer there; purple: more; saturated at 2x); " + legend
        )
    scale = 0.12 * max(x1 - x0, y1 - y0)
    for items, colour in ((rb.supports, "#2166ac"), (rb.loads, "#d6332a")):
        for what, sel in items:
            for _, _, lines in sel.lateral:
                for g in getattr(lines, "geoms", [lines]):
                    if g.is_empty:
                        continue
                    cv.items.append(
                        f'<path d="{cv._d(np.asarray(g.coords))}" fill="none" stroke="{colour}" '
                        'stroke-width="4" stroke-linecap="round"/>'
                    )
            force = getattr(what, "force", None)
            if force is not None and sel.lateral and np.hypot(force[0], force[1]) > 0:
                g = shapely.union_all([ln for _, _, ln in sel.lateral])
                c = np.asarray(g.centroid.coords[0])
                d = np.asarray(force[:2], dtype=float)
                d /= np.hypot(*d)
                a, b = cv.xy(c - scale * d)[0], cv.xy(c)[0]
                n = np.array([-(b - a)[1], (b - a)[0]]) / max(np.hypot(*(b - a)), 1e-9)
                u = (b - a) / max(np.hypot(*(b - a)), 1e-9)
                h1, h2 = b - 10 * u + 5 * n, b - 10 * u - 5 * n
                cv.items.append(
                    f'<path d="M{a[0]:.1f} {a[1]:.1f} L{b[0]:.1f} {b[1]:.1f} M{h1[0]:.1f} {h1[1]:.1f} '
                    f'L{b[0]:.1f} {b[1]:.1f} L{h2[0]:.1f} {h2[1]:.1f}" fill="none" stroke="{colour}" '
                    'stroke-width="2.5"/>'
                )
                cv.text(b[0] + 6, b[1] - 6, f"{what.name}: {np.hypot(*force[:2]):g} N", 12)
            elif sel.lateral:
                g = shapely.union_all([ln for _, _, ln in sel.lateral])
                p = cv.xy(np.asarray(g.centroid.coords[0]))[0]
                cv.text(p[0] + 6, p[1] - 6, what.name, 12)
    cv.text(cv.pad + 4, cv.pad + 14, f"{rb.name} ({rb.analysis})", 13)
    h = cv.height + 22
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{h}" viewBox="0 0 {width} {h}">'
        f'<rect width="100%" height="100%" fill="white"/>{"".join(cv.items)}'
        f'<text x="8" y="{cv.height + 14}" font-size="11" font-family="sans-serif">{legend}</text></svg>'
    )
