"""Helpers for the splicer tests: regions and new paths for real blocks, without the engines.

The region of a block is rebuilt from its own extrusions (beads of its width, closed over its line
spacing); the new paths are rectilinear lines at another angle (:func:`loadpath.metrics.rectilinear`),
so the splicer is tested on real files independently of the FEA and the engines.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import shapely
from loadpath import gcode
from loadpath.gcode.flavors import Role
from loadpath.metrics import rectilinear
from loadpath.plugin import settings as S
from loadpath.splice import BlockFill, splice
from loadpath.splice.verify import check_splice
from loadpath.toolpath import Path

SLICED_CASES = {
    "prusa-relE": ("prusa", "ohs", "mixed", {}),
    "prusa-absE": (
        "prusa",
        "ohs",
        "solid",
        {"use_relative_e_distances": 0, "before_layer_gcode": '""', "layer_gcode": '""'},
    ),
    "prusa-fwretract": ("prusa", "ohs", "mixed", {"use_firmware_retraction": 1, "wipe": 0}),
    "prusa-volumetricE": ("prusa", "ohs", "mixed", {"use_volumetric_e": 1}),
    "prusa-two-objects": ("prusa", "two_objects", "mixed", {}),
    "cura-absE": ("cura", "ohs", "mixed", {}),
    "cura-relE": ("cura", "ohs", "solid", {"relative_extrusion": "true"}),
    "cura-two-objects": ("cura", "two_objects", "mixed", {}),
}
"""Real files the splicer tests slice: name -> (slicer, part, settings, overrides)."""

INFILL = (Role.SOLID_INFILL, Role.SPARSE_INFILL, Role.SKIN)


def block_region(program, b):
    """(region, flow width, spacing) of a block, from its own extrusions."""
    mv = program.moves[b.moves]
    mv = mv[mv["extrude"]]
    seg = np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"])
    h = float(np.median(mv["height"]))
    d = 1.75
    fw = float(np.sum(mv["e"]) * np.pi * d * d / 4 / max(seg.sum(), 1e-9) / h)
    lines = shapely.linestrings(
        np.stack([np.stack([mv["x0"], mv["y0"]], 1), np.stack([mv["x1"], mv["y1"]], 1)], 1)
    )
    beads = shapely.union_all(shapely.buffer(lines, fw / 2, cap_style="flat"))
    spacing = max(fw, beads.convex_hull.area / max(seg.sum(), 1e-9))
    for _ in range(2):  # the hull overestimates concave regions: close, measure, close again
        r = spacing * 0.75
        region = beads.buffer(r, join_style="mitre").buffer(-r, join_style="mitre")
        spacing = max(fw, region.area / max(seg.sum(), 1e-9))
    if region.geom_type not in ("Polygon", "MultiPolygon"):
        region = shapely.union_all([g for g in getattr(region, "geoms", [region]) if g.area > 0])
    return region, fw, spacing


def infill_blocks(program, first_last=False):
    """Indices of infill blocks (not in the first or last layer unless asked)."""
    n = len(program.layers)
    out = []
    for i in range(len(program.blocks)):
        b = program.block(i)
        if b.role in INFILL and (first_last or 0 < b.layer < n - 1) and b.e > 0:
            out.append(i)
    return out


def rectilinear_fills(program, blocks, angle=30.0, pitch_scale=1.0):
    """A BlockFill per block: rectilinear lines at ``angle`` over the block's region."""
    fills = []
    for i in blocks:
        b = program.block(i)
        region, fw, spacing = block_region(program, b)
        pitch = spacing * pitch_scale
        inner = region.buffer(-fw / 2)
        if inner.is_empty:
            continue
        tp = rectilinear(inner, pitch, angle_deg=angle)
        sparse = spacing > 1.5 * fw
        fills.append(BlockFill(i, tp.paths, region, flow_width=fw if sparse else None, nominal_pitch=pitch))
    return fills


def own_paths_fill(program, i, flow_width):
    """The block's own extrusion polylines as paths (consecutive extrusions joined)."""
    b = program.block(i)
    mv = program.moves[b.moves]
    ext = mv["extrude"]
    paths, cur = [], []
    for row, e in zip(mv, ext, strict=True):
        if e:
            if not cur:
                cur = [(row["x0"], row["y0"])]
            cur.append((row["x1"], row["y1"]))
        elif cur:
            paths.append(cur)
            cur = []
    if cur:
        paths.append(cur)
    out = tuple(Path(np.array(p), np.full(len(p), flow_width)) for p in paths if len(p) >= 2)
    return BlockFill(i, out, None, flow_width=flow_width)


def run_splice(program, fills, volume_tol=0.03, options=None, **overrides):
    """Splice with the file's own settings; returns (result, output program, check).

    ``overrides``: settings (``--set`` keys); ``options``: :class:`loadpath.splice.SpliceOptions`
    fields set on what the settings give (e.g. ``{"arcs": None}``).
    """
    s = S.resolve(program)
    if overrides:
        s = s.with_values(overrides, "test")
    opts = dataclasses.replace(S.splice_options(s), volume_tol=volume_tol, **(options or {}))
    result = splice(program, fills, opts)
    out = gcode.parse(result.data)
    regions = {f.block: f.region for f in fills if f.region is not None}
    return result, out, check_splice(program, out, result, regions=regions)
