"""Plain-text summaries of a print's layers and of a resolved load case (``loadpath inspect``).

The command line only prints what these functions return; everything it shows is computed here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from loadpath.areal import EMPTY, as_region
from loadpath.gcode.model import Program
from loadpath.geometry.classify import DEFAULT_REPLACE
from loadpath.geometry.groups import group_regions
from loadpath.geometry.model import LayerGeometry, PrintGeometry

__all__ = ["LayerRow", "layer_rows", "format_layer_table", "distinct_file_layers", "describe_resolved"]


@dataclass(frozen=True)
class LayerRow:
    """One line of the per-layer table.

    Attributes
    ----------
    layer : int
        0-based index into ``Program.layers`` (Cura's ``;LAYER:n``); the table prints ``layer + 1``, as
        the slicers' previews and loadpath's messages count layers.
    z, height : float, mm
    features : tuple of str
        The slicer's feature names printed in the layer, in file order.
    objects : int
        Objects with perimeters in the layer.
    islands : int
        Islands over all objects.
    infill_area : float, mm^2
        Area of the infill domains.
    kinds : tuple of str
        Kinds of the infill blocks (sorted).
    replace_area : float, mm^2
        Area of the replace regions for the chosen kinds.
    group : int
        Distinct-layer group (:func:`distinct_file_layers`), -1 for a layer without objects.
    """

    layer: int
    z: float
    height: float
    features: tuple[str, ...]
    objects: int
    islands: int
    infill_area: float
    kinds: tuple[str, ...]
    replace_area: float
    group: int


def distinct_file_layers(geometry: PrintGeometry, kinds: Sequence[str] = DEFAULT_REPLACE) -> dict[int, int]:
    """Group the file's layers (all objects together) by part outline and replace region.

    Returns
    -------
    dict of int -> int
        Group of every layer index that has geometry; groups numbered from 0 in file order.
    """
    layers = sorted({g.layer_index for o in geometry.objects for g in o.layers})
    per = {i: geometry.at(i) for i in layers}
    outlines = [_union([g.outline for g in per[i]]) for i in layers]
    replace = [_union([g.replace_region(kinds) for g in per[i]]) for i in layers]
    keys1 = [tuple(sorted((g.object, g.kinds, round(g.height, 3)) for g in per[i])) for i in layers]
    first = group_regions(outlines, keys1)
    second = group_regions(replace, first)
    return dict(zip(layers, second, strict=True))


def _union(regions: Sequence[Any]) -> Any:
    import shapely

    parts = [r for r in regions if not r.is_empty]
    return as_region(shapely.union_all(parts)) if parts else EMPTY


def layer_rows(program: Program, geometry: PrintGeometry,
               kinds: Sequence[str] = DEFAULT_REPLACE) -> list[LayerRow]:
    """Summarise every layer of the file as a :class:`LayerRow`."""
    groups = distinct_file_layers(geometry, kinds)
    b = program.blocks
    rows = []
    for layer in program.layers:
        geo: list[LayerGeometry] = geometry.at(layer.index)
        feats = b["feature"][b["layer"] == layer.index]
        names = tuple(program.features[int(f)] for f in dict.fromkeys(feats.tolist()) if f >= 0)
        heights = [g.height for g in geo]
        rows.append(LayerRow(
            layer=layer.index, z=float(layer.z),
            height=float(np.median(heights)) if heights else float(layer.height),
            features=names, objects=len(geo), islands=sum(len(g.islands) for g in geo),
            infill_area=float(sum(g.domain.area for g in geo)),
            kinds=tuple(sorted({k for g in geo for k in g.kinds})),
            replace_area=float(sum(g.replace_region(kinds).area for g in geo)),
            group=groups.get(layer.index, -1)))
    return rows


def format_layer_table(rows: Sequence[LayerRow], kinds: Sequence[str] = DEFAULT_REPLACE) -> str:
    """Format the rows as an aligned text table (one header line, one line per layer, counted from 1)."""
    head = ("layer", "z mm", "h mm", "islands", "infill mm2", f"replace mm2 ({'+'.join(kinds)})", "kinds",
            "group", "features")
    body = [(str(r.layer + 1), f"{r.z:.3f}", f"{r.height:.3f}", str(r.islands), f"{r.infill_area:.1f}",
             f"{r.replace_area:.1f}", "+".join(r.kinds) or "-", _group_name(r.group),
             ", ".join(r.features) or "-") for r in rows]
    widths = [max(len(h), *(len(row[i]) for row in body)) if body else len(h) for i, h in enumerate(head)]

    def line(cells: Sequence[str]) -> str:
        return "  ".join(c.rjust(w) if i < 6 else c.ljust(w)
                         for i, (c, w) in enumerate(zip(cells, widths, strict=True))).rstrip()

    return "\n".join([line(head)] + [line(row) for row in body])


def _group_name(g: int) -> str:
    """0 -> A, 25 -> Z, 26 -> AA; -1 -> '-'."""
    if g < 0:
        return "-"
    out = ""
    g += 1
    while g:
        g, r = divmod(g - 1, 26)
        out = chr(65 + r) + out
    return out


def describe_resolved(resolved: Any) -> list[str]:
    """Lines describing a resolved body: its analysis and what each selector picked.

    Parameters
    ----------
    resolved : loadpath.loadcase.ResolvedBody

    Returns
    -------
    list of str
        ``object 'ohs.stl': 2d (reason)``, then one line per support / load with the picked boundary
        length (xy, mm), the picked area (mm^2) and the bounding box of the picked lines.
    """
    lo, hi = resolved.body.bounds
    out = [f"object {resolved.name!r}: {resolved.analysis} analysis ({resolved.reason}); "
           f"{len(resolved.body.slabs)} slab(s); bounding box {resolved.body.describe_bounds()}"]
    items = [("support", s, sel) for s, sel in resolved.supports]
    items += [("load", ld, sel) for ld, sel in resolved.loads]
    for role, item, sel in items:
        lines = sel.lines
        length = float(lines.length) if lines is not None else 0.0
        if lines is not None and not lines.is_empty:
            x0, y0, x1, y1 = lines.bounds
            box = f"x {x0:.3f}..{x1:.3f}, y {y0:.3f}..{y1:.3f}"
        else:
            box = "-"
        what = ""
        if role == "support":
            what = f"fix {'/'.join(item.fix)}"
        elif item.force is not None:
            what = "force (" + ", ".join(f"{v:g}" for v in item.force) + ") N"
        elif item.pressure is not None:
            what = f"pressure {item.pressure:g} MPa"
        out.append(f"  {role} {sel.name!r} ({sel.selector.describe()}): {what}; picked boundary length "
                   f"{length:.3f} mm, area {sel.measure(resolved.analysis):.3f} mm2, lines in {box}")
    out += [f"  warning: {w}" for w in resolved.held_loads()]
    return out
