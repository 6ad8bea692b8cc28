"""Small SVG drawing for the report: regions, coloured segments, stress ticks, histograms.

No plotting library: the report must work from a plain install.  Segments are grouped by colour
(values quantized to :data:`LEVELS` steps of the colour map), so a layer with ten thousand segments
is a few dozen ``<path>`` elements.  Coordinates are millimetres on the bed, y up.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from loadpath._typing import Floats, Points2, Region

__all__ = ["Canvas", "colormap", "histogram", "LEVELS", "colorbar"]

LEVELS = 24
"""Colour steps of coloured segments."""

# viridis at 9 stops (matplotlib's table, public domain colour map by van der Walt & Smith)
_VIRIDIS = np.array(
    [
        [68, 1, 84],
        [71, 44, 122],
        [59, 81, 139],
        [44, 113, 142],
        [33, 144, 141],
        [39, 173, 129],
        [92, 200, 99],
        [170, 220, 50],
        [253, 231, 37],
    ],
    dtype=float,
)


def colormap(values: Floats) -> list[str]:
    """Hex colours of values in [0, 1] (clipped), viridis."""
    v = np.clip(np.nan_to_num(np.asarray(values, dtype=float), nan=0.0), 0.0, 1.0) * (len(_VIRIDIS) - 1)
    i = np.minimum(v.astype(int), len(_VIRIDIS) - 2)
    t = (v - i)[:, None]
    rgb = np.round(_VIRIDIS[i] * (1 - t) + _VIRIDIS[i + 1] * t).astype(int)
    return [f"#{r:02x}{g:02x}{b:02x}" for r, g, b in rgb]


class Canvas:
    """Maps bed millimetres to pixels and collects SVG elements.

    Parameters
    ----------
    bounds : (x0, y0, x1, y1), mm
    width : int, px
    pad : int, px
    """

    def __init__(self, bounds: Sequence[float], width: int = 960, pad: int = 8) -> None:
        x0, y0, x1, y1 = (float(b) for b in bounds)
        span = max(x1 - x0, 1e-9)
        self.s = (width - 2 * pad) / span
        self.x0, self.y1, self.pad = x0, y1, pad
        self.width = width
        self.height = int(round((y1 - y0) * self.s + 2 * pad))
        self.items: list[str] = []

    def xy(self, pts: Points2) -> np.ndarray:
        """Pixel coordinates of points (n, 2)."""
        p = np.asarray(pts, dtype=float).reshape(-1, 2)
        return np.column_stack(
            [(p[:, 0] - self.x0) * self.s + self.pad, (self.y1 - p[:, 1]) * self.s + self.pad]
        )

    def _d(self, pts: Points2, close: bool = False) -> str:
        q = self.xy(pts)
        body = " L".join(f"{x:.1f} {y:.1f}" for x, y in q)
        return f"M{body}{' Z' if close else ''}"

    def region(self, region: Region, fill: str = "#f2f2f2", stroke: str = "#999999") -> None:
        """Draw a filled region with its holes."""
        polys = getattr(region, "geoms", [region])
        d = []
        for p in polys:
            if p.is_empty:
                continue
            d.append(self._d(np.asarray(p.exterior.coords), True))
            d += [self._d(np.asarray(r.coords), True) for r in p.interiors]
        if d:
            self.items.append(
                f'<path d="{" ".join(d)}" fill="{fill}" fill-rule="evenodd" stroke="{stroke}" '
                'stroke-width="0.8"/>'
            )

    def segments(
        self,
        a: Points2,
        b: Points2,
        values: Floats,
        width_mm: float | Floats,
        opacity: float = 1.0,
        stroke: str | None = None,
    ) -> None:
        """Draw segments ``a[i] -> b[i]`` coloured by ``values`` in [0, 1] (or ``stroke``), ``width_mm``."""
        if len(a) == 0:
            return
        if stroke is not None:
            values = np.zeros(len(a))
        pa, pb = self.xy(a), self.xy(b)
        level = np.clip(
            np.round(np.nan_to_num(np.asarray(values, dtype=float)) * (LEVELS - 1)), 0, LEVELS - 1
        )
        widths = np.broadcast_to(np.asarray(width_mm, dtype=float), (len(a),)) * self.s
        wl = np.round(widths * 2) / 2
        colours = colormap(np.arange(LEVELS) / (LEVELS - 1))
        keys = level.astype(int) * 10_000 + np.round(wl * 10).astype(int)
        for k in np.unique(keys):
            sel = keys == k
            d = "".join(
                f"M{x0:.1f} {y0:.1f}L{x1:.1f} {y1:.1f}"
                for (x0, y0), (x1, y1) in zip(pa[sel], pb[sel], strict=True)
            )
            w = max(float(wl[sel][0]), 0.5)
            self.items.append(
                f'<path d="{d}" stroke="{stroke or colours[int(k // 10_000)]}" stroke-width="{w:.1f}" '
                f'stroke-linecap="round" fill="none" opacity="{opacity}"/>'
            )

    def text(
        self, x_px: float, y_px: float, s: str, size: int = 12, anchor: str = "start", fill: str = "#000000"
    ) -> None:
        """Write a label at pixel coordinates."""
        self.items.append(
            f'<text x="{x_px:.1f}" y="{y_px:.1f}" font-size="{size}" text-anchor="{anchor}" '
            f'font-family="sans-serif" fill="{fill}">{_esc(s)}</text>'
        )

    def svg(self, title: str = "") -> str:
        """Return the SVG document."""
        head = f"<title>{_esc(title)}</title>" if title else ""
        return (
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{self.width}" height="{self.height}" '
            f'viewBox="0 0 {self.width} {self.height}">{head}<rect width="100%" height="100%" fill="white"/>'
            + "".join(self.items)
            + "</svg>"
        )


def colorbar(label: str, width: int = 320, height: int = 34) -> str:
    """Draw a horizontal viridis colour bar from 0 to 1 with a label."""
    cols = colormap(np.linspace(0, 1, 64))
    step = (width - 20) / 64
    rects = "".join(
        f'<rect x="{10 + i * step:.1f}" y="4" width="{step + 0.5:.1f}" height="12" fill="{c}"/>'
        for i, c in enumerate(cols)
    )
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}">{rects}'
        f'<text x="10" y="30" font-size="11" font-family="sans-serif">0</text>'
        f'<text x="{width - 10}" y="30" font-size="11" text-anchor="end" font-family="sans-serif">1</text>'
        f'<text x="{width / 2}" y="30" font-size="11" text-anchor="middle" font-family="sans-serif">'
        f"{_esc(label)}</text></svg>"
    )


def histogram(
    series: Sequence[tuple[str, Floats, str]],
    lo: float,
    hi: float,
    bins: int = 40,
    width: int = 460,
    height: int = 200,
    xlabel: str = "",
) -> str:
    """Overlaid step histograms (normalised to densities) of several series ``(label, values, colour)``."""
    edges = np.linspace(lo, hi, bins + 1)
    dens = []
    for _, v, _ in series:
        v = np.asarray(v, dtype=float)
        v = v[np.isfinite(v)]
        h, _ = (
            np.histogram(np.clip(v, lo, hi), bins=edges, density=True) if len(v) else (np.zeros(bins), edges)
        )
        dens.append(h)
    top = max((float(d.max()) for d in dens), default=1.0) or 1.0
    ml, mb, mt = 36, 30, 10
    pw, ph = width - ml - 10, height - mb - mt

    def px(x: float) -> float:
        return ml + (x - lo) / (hi - lo) * pw

    def py(y: float) -> float:
        return mt + ph - y / top * ph

    items = [
        f'<line x1="{ml}" y1="{mt + ph}" x2="{ml + pw}" y2="{mt + ph}" stroke="#333"/>',
        f'<line x1="{ml}" y1="{mt}" x2="{ml}" y2="{mt + ph}" stroke="#333"/>',
    ]
    for t in np.linspace(lo, hi, 6):
        items.append(
            f'<text x="{px(t):.1f}" y="{mt + ph + 14}" font-size="10" text-anchor="middle" '
            f'font-family="sans-serif">{t:g}</text>'
        )
    for k, ((label, _, colour), h) in enumerate(zip(series, dens, strict=True)):
        pts = []
        for i in range(bins):
            pts += [(px(edges[i]), py(h[i])), (px(edges[i + 1]), py(h[i]))]
        d = "M" + " L".join(f"{x:.1f} {y:.1f}" for x, y in pts)
        items.append(f'<path d="{d}" stroke="{colour}" stroke-width="1.6" fill="none"/>')
        items.append(
            f'<text x="{ml + pw - 4}" y="{mt + 12 + 14 * k}" font-size="11" text-anchor="end" '
            f'fill="{colour}" font-family="sans-serif">{_esc(label)}</text>'
        )
    items.append(
        f'<text x="{ml + pw / 2}" y="{height - 2}" font-size="11" text-anchor="middle" '
        f'font-family="sans-serif">{_esc(xlabel)}</text>'
    )
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}">'
        f'<rect width="100%" height="100%" fill="white"/>{"".join(items)}</svg>'
    )


def _esc(s: str) -> str:
    return str(s).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
