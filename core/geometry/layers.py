"""Build the layer geometry of a parsed G-code program.

For each layer and each object: the part outline and the infill domain from the perimeters
(:mod:`.walls`), split into islands; each infill block's lines assigned to the islands, its pitch
(:mod:`.pitch`), footprint and region (:mod:`.regions`); then, with the layers below and above known,
each block's kind (:mod:`.classify`); finally every region is checked against its block's own
extrusions.

Widths: the **flow width** of a move is its extruded cross-section over its height (:mod:`.flow`:
``e * (pi D^2 / 4) / (length * height)``, the filament diameter ``D`` from the file's configuration or
measured from its walls); the **bead width** is the slicer's ``;WIDTH:`` (the flow width when there
is none).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

import numpy as np
import shapely
from loadpath._typing import Floats, Ints, Region
from loadpath import budget
from loadpath.areal import EMPTY, as_region, polygons_of
from loadpath.errors import BudgetError, GeometryError
from loadpath.gcode.flavors import Role
from loadpath.gcode.model import Program
from loadpath.geometry.classify import SOLID_DENSITY, classify, exposed_fraction
from loadpath.geometry.flow import filament_diameter, flow_widths
from loadpath.geometry.model import InfillBlock, Island, LayerGeometry, ObjectGeometry, PrintGeometry
from loadpath.geometry.pitch import PitchEstimate, estimate_pitch
from loadpath.geometry.regions import (
    DENSE_PITCH,
    BlockLines,
    check_tolerance,
    footprints,
    outside_distance,
    regions,
)
from loadpath.geometry.walls import walls

__all__ = ["layer_geometry", "object_names", "MIN_STRAIGHT"]

MIN_STRAIGHT = 0.7
"""Share of a block's length its straight line families must carry for their spacing to be its pitch
(rectilinear, lines, grid, triangles carry 0.84-1.0 with their anchors; honeycomb about 0.5)."""

_PERIMETER = np.array([Role.PERIMETER, Role.EXTERNAL_PERIMETER, Role.OVERHANG_PERIMETER])
_INSIDE = np.array([r for r in Role if r.is_infill] + [Role.GAP_FILL, Role.IRONING])
_SEGMENTS_FIX = ("check the file for a damaged or repeated stretch of G-code (one layer of a real part has some "
                 "thousands); loadpath stopped before deriving the layer's regions")
_FIX = ("slice with at least one perimeter (PrusaSlicer: perimeters >= 1; Cura: wall_line_count >= 1); "
        "loadpath finds the infill domain from the perimeters")


def object_names(labels: Iterable[str]) -> list[str]:
    """Short, unique names for object labels (``"bracket.stl id:1 copy 0"`` -> ``"bracket.stl"``)."""
    labels = list(labels)
    bare = [re.sub(r"\s+id:\d+\s+copy\s+\d+\s*$", "", lb).strip() for lb in labels]
    short = [re.split(r"[\\/]", b)[-1] or lb for b, lb in zip(bare, labels, strict=True)]
    return [s if short.count(s) == 1 else lb for s, lb in zip(short, labels, strict=True)]


def layer_geometry(
    program: Program, check: bool = True, cache: Any = None, workers: int = 1, outlines_only: bool = False
) -> PrintGeometry:
    """Derive the layer geometry of every object of a program.

    Parameters
    ----------
    program : Program
        From :func:`loadpath.gcode.read` / :func:`~loadpath.gcode.parse`.
    check : bool
        Raise when a block's extrusions leave its derived region (see :mod:`.regions`).
    cache : loadpath.cache.Cache, optional
        Keeps each layer's islands of each object under :func:`islands_key` (what they are derived
        from): a re-export finds those of every layer it extrudes the same (PrusaSlicer at other
        speeds: 22 of the gusset's 40 layers, 8 of the example's 10).  The classification across
        layers and the check are made again.
    workers : int
        Processes for the islands the cache does not hold (:func:`loadpath.procs.fork_map`: forked,
        they inherit the program; each layer's islands depend on that layer alone, so they are the
        same whatever the number of workers).  The 1000-layer specimen's islands took 6-10 s of one
        core's time.
    outlines_only : bool
        Islands with their outline and infill domain but no blocks (their footprints and regions
        are most of the work: 2.2 of 3.2 s on a 40-layer gusset's three files): for a caller that
        needs the part's body only (:meth:`PrintGeometry.bodies`).  Neither kept in nor read from
        the cache, and not checked.

    Returns
    -------
    PrintGeometry

    Raises
    ------
    GeometryError
        A layer with infill but no perimeters; a region its own block's lines leave (``check``).
    """
    m = program.moves
    diameter, source = filament_diameter(program)
    fw_all = flow_widths(m, diameter)
    bead_all = np.where(np.isfinite(m["width"]) & (m["width"] > 0), m["width"], fw_all)
    work = m["extrude"] & (m["layer"] >= 0) & np.isfinite(fw_all) & (fw_all > 0)
    peri = work & np.isin(m["role"], _PERIMETER)
    inside = work & np.isin(m["role"], _INSIDE)
    rows = np.flatnonzero(peri | inside)
    block_of = np.full(len(m), -1, dtype=np.int64)
    for i, (a, b) in enumerate(zip(program.blocks["move_start"], program.blocks["move_stop"], strict=True)):
        block_of[a:b] = i

    codes = sorted({int(c) for c in np.unique(m["object"][rows])})
    names = object_names([program.objects[c] if c >= 0 else "part" for c in codes])
    per_object: dict[int, list[LayerGeometry]] = {c: [] for c in codes}
    kept = False
    todo: list[tuple[int, Ints, Ints, str]] = []  # (index in made, perimeter rows, inside rows, where)
    made: list[tuple[int, int, float, str, Any, tuple[str, int] | None]] = []  # (code, layer, height, name, islands, key)
    layer_rows = np.split(rows, np.searchsorted(m["layer"][rows], np.arange(1, len(program.layers))))
    for li, lr in enumerate(layer_rows):
        if len(lr) == 0:
            continue
        layer = program.layers[li]
        for code, name in zip(codes, names, strict=True):
            r = lr[m["object"][lr] == code]
            if len(r) == 0:
                continue
            p_rows, i_rows = r[peri[r]], r[inside[r]]
            where = f"layer {li + 1} (z = {layer.z:g} mm), object {name!r}"
            if len(p_rows) == 0:
                raise GeometryError(f"{where} has infill but no perimeters; {_FIX}")
            height = float(np.median(m["height"][p_rows]))
            budget.check(len(r), budget.LAYER_SEGMENTS, where, "extrusion segments", _SEGMENTS_FIX)
            key = None
            if cache is not None and not outlines_only:
                key = islands_key(m, p_rows, i_rows, fw_all, bead_all, block_of, program)
            islands = _rebased(cache.get("islands", key[0]), key[1]) if key else None
            if islands is None:
                todo.append((len(made), p_rows, i_rows, where))
            made.append((code, li, height, name, islands, key))

    global _WORK
    _WORK = [(m, fw_all, bead_all, block_of, program, todo, outlines_only)]
    try:
        from loadpath.procs import fork_map, spans

        # contiguous batches: one round trip per few dozen layers, not per layer
        found = [isl for got in fork_map(_islands_batch, spans(len(todo), workers, 4), workers) for isl in got]
    finally:
        _WORK = []
    for (k, _, _, _), islands in zip(todo, found, strict=True):
        code, li, height, name, _, key = made[k]
        made[k] = (code, li, height, name, islands, key)
        if key:
            kept = cache.put("islands", key[0], _rebased(islands, -key[1]), evict=False) or kept
    for code, li, height, name, islands, _ in made:
        per_object[code].append(LayerGeometry(li, float(program.layers[li].z), height, name, islands))

    if kept:
        cache.evict()
    objects = []
    for code, name in zip(codes, names, strict=True):
        layers = per_object[code] if outlines_only else _classified(per_object[code])
        if check and not outlines_only:
            _check(layers, program)
        objects.append(ObjectGeometry(name, program.objects[code] if code >= 0 else "", code, tuple(layers)))
    return PrintGeometry(tuple(objects), program.dialect, len(program.layers), diameter, source)


_WORK: list[tuple] = []
"""What :func:`layer_geometry` hands to :func:`_islands_batch` (inherited by forked workers, not
pickled): ``(moves, flow widths, bead widths, block of each move, program, todo, outlines only)``."""


def _islands_batch(span: tuple[int, int]) -> list[tuple[Island, ...]]:
    """:func:`_islands` of the layers ``todo[a:z]`` of :data:`_WORK`, a budget error naming its layer."""
    m, fw_all, bead_all, block_of, program, todo, outlines_only = _WORK[0]
    out = []
    for _, p_rows, i_rows, where in todo[span[0] : span[1]]:
        try:
            out.append(_islands(m, p_rows, i_rows, fw_all, bead_all, block_of, program, outlines_only))
        except BudgetError as exc:
            raise exc.at(where) from None
    return out


_ISLAND_MOVES = ("x0", "y0", "x1", "y1", "e", "width", "height", "role", "feature")


def islands_key(m: np.ndarray, p_rows: Ints, i_rows: Ints, fw_all: Floats, bead_all: Floats, block_of: Ints,
                program: Program) -> tuple[str, int]:
    """Key of one layer's islands of one object in the cache, and the block numbering's base.

    What :func:`_islands` reads: the perimeter and infill rows' :data:`_ISLAND_MOVES` columns, flow
    and bead widths (these carry the file's filament diameter), their blocks numbered from the
    layer's first one (``base``: a block added or dropped earlier in the file shifts the numbers,
    not the islands), those blocks' lengths and the feature names; :func:`loadpath.cache.code_stamp`
    and the G-code package's sources (:func:`loadpath.cache.source_stamp`, the roles).  Exact bytes:
    a hit gives the very islands a new derivation would.
    """
    from loadpath.cache import code_stamp, digest, source_stamp

    blk = block_of[i_rows]
    inside = blk[blk >= 0]
    base = int(inside.min()) if len(inside) else 0
    parts: list[bytes | str] = ["islands", code_stamp(), source_stamp("gcode")]
    parts.append(f"{len(p_rows)} {len(i_rows)}")
    for rows in (p_rows, i_rows):
        parts += [np.ascontiguousarray(m[k][rows]).tobytes() for k in _ISLAND_MOVES]
        parts += [np.ascontiguousarray(w[rows]).tobytes() for w in (fw_all, bead_all)]
    parts.append(np.where(blk >= 0, blk - base, -1).astype(np.int64).tobytes())
    used = np.unique(inside)
    parts.append(np.ascontiguousarray(program.blocks["length"][used]).tobytes())
    parts.append(repr(tuple(program.features)))
    return digest(parts), base


def _rebased(islands: Any, base: int) -> tuple[Island, ...] | None:
    """``islands`` with every block's index moved by ``base`` (None when not a tuple of islands)."""
    from dataclasses import replace

    if not isinstance(islands, tuple) or not all(isinstance(i, Island) for i in islands):
        return None
    if base == 0:
        return islands
    return tuple(
        replace(isl, blocks=tuple(
            replace(b, block_index=b.block_index + base) if b.block_index >= 0 else b for b in isl.blocks
        ))
        for isl in islands
    )


def _islands(m: np.ndarray, p_rows: Ints, i_rows: Ints, fw_all: Floats, bead_all: Floats, block_of: Ints,
             program: Program, outlines_only: bool = False) -> tuple[Island, ...]:
    """Islands of one object in one layer, with their (unclassified) blocks (none: ``outlines_only``)."""
    x0, y0, x1, y1 = (m[k] for k in ("x0", "y0", "x1", "y1"))
    mx, my = (x0[i_rows] + x1[i_rows]) / 2, (y0[i_rows] + y1[i_rows]) / 2
    w = walls(x0[p_rows], y0[p_rows], x1[p_rows], y1[p_rows], bead_all[p_rows], fw_all[p_rows],
              m["role"][p_rows] == Role.EXTERNAL_PERIMETER, mx, my)
    polys = sorted(polygons_of(w.outline), key=lambda p: (round(p.bounds[0], 3), round(p.bounds[1], 3)))
    if not polys:
        return ()
    if outlines_only:
        return tuple(
            Island(k, poly, as_region(shapely.intersection(w.domain, poly)) if not w.domain.is_empty else EMPTY)
            for k, poly in enumerate(polys)
        )
    # the island of every inside row: containing outline, else the nearest one
    owner = np.full(len(i_rows), -1, dtype=np.int64)
    for k, poly in enumerate(polys):
        shapely.prepare(poly)
        owner[(owner < 0) & shapely.contains_xy(poly, mx, my)] = k
    lost = owner < 0
    if lost.any():
        pts = shapely.points(mx[lost], my[lost])
        d = shapely.distance(np.array(polys, dtype=object)[:, None], pts[None, :])
        owner[lost] = np.argmin(d, axis=0)
    blk = block_of[i_rows]
    out = []
    for k, poly in enumerate(polys):
        domain = as_region(shapely.intersection(w.domain, poly)) if not w.domain.is_empty else EMPTY
        mine = i_rows[owner == k]
        ids = list(dict.fromkeys(blk[owner == k].tolist()))  # blocks in file order
        lines, meta = [], []
        for b in ids:
            r = mine[block_of[mine] == b]
            fw = float(np.sum(fw_all[r] * _len(m, r)) / np.sum(_len(m, r)))
            est = estimate_pitch(x0[r], y0[r], x1[r], y1[r], fw)
            if est.straight_share < MIN_STRAIGHT:  # honeycomb, gyroid, ...: measured by area below
                est = PitchEstimate(float("nan"), float("nan"), est.directions, est.straight_share)
            lines.append(BlockLines(x0[r], y0[r], x1[r], y1[r], fw, est.pitch))
            total = float(program.blocks["length"][b]) if b >= 0 else float(np.sum(_len(m, r)))
            meta.append((b, r, fw, est, float(np.sum(_len(m, r))), total))
        lines = [_full_pitch(_with_pitch(bl, domain, len(lines) == 1), Role(int(m["role"][mt[1][0]])))
                 for bl, mt in zip(lines, meta, strict=True)]
        prints = footprints(lines, domain)
        regs = regions(domain, prints) if lines else []
        blocks = []
        for (b, r, fw, est, length, total), bl, fp, reg in zip(meta, lines, prints, regs, strict=True):
            feat = int(m["feature"][r[0]])
            role = Role(int(m["role"][r[0]]))
            density = float(length * fw / reg.area) if reg.area > (4 * fw) ** 2 else float("nan")
            blocks.append(InfillBlock(
                block_index=int(b), feature=program.features[feat] if feat >= 0 else "", role=role,
                kind="", region=reg, footprint=fp, flow_width=fw,
                bead_width=_bead_width(m["width"][r], fw), height=float(np.median(m["height"][r])),
                pitch=bl.pitch, angle=est.angle, density=density, length=length,
                share=min(1.0, length / total) if total > 0 else 1.0, outside=outside_distance(bl, reg)))
        out.append(Island(k, poly, domain, tuple(blocks)))
    return tuple(out)


def _bead_width(widths: np.ndarray, flow_width: float) -> float:
    """Return the slicer's nominal width of a block (median ``;WIDTH:``), its flow width when it has none."""
    ok = np.isfinite(widths) & (widths > 0)
    return float(np.median(widths[ok])) if ok.any() else flow_width


def _len(m: np.ndarray, r: Ints) -> Floats:
    return np.hypot(m["x1"][r] - m["x0"][r], m["y1"][r] - m["y0"][r])


def _with_pitch(bl: BlockLines, domain: Region, alone: bool) -> BlockLines:
    """Fill in the pitch of curved patterns: ``area / length`` of the area its lines span.

    The area is the island's domain when the block is alone in it, else the block's lines closed
    over a radius that grows with the pitch found (2.5 mm first).
    """
    if np.isfinite(bl.pitch):
        return bl
    length = float(np.sum(np.hypot(bl.x1 - bl.x0, bl.y1 - bl.y0)))
    if length <= 0 or domain.is_empty:
        return BlockLines(bl.x0, bl.y0, bl.x1, bl.y1, bl.flow_width, bl.flow_width)
    if alone:
        pitch = domain.area / length
    else:
        r, pitch = 2.5, 0.0
        for _ in range(3):
            span = shapely.intersection(as_region(shapely.buffer(bl.beads(grow=r), -r)), domain)
            pitch = span.area / length
            if pitch < 1.5 * r:
                break
            r = 0.75 * pitch
    return BlockLines(bl.x0, bl.y0, bl.x1, bl.y1, bl.flow_width, float(max(pitch, bl.flow_width)))


_FULL = frozenset({*(r for r in Role if r.is_solid_infill), Role.BRIDGE_INFILL, Role.GAP_FILL})
"""Roles every slicer prints at 100 %: their lines stand about one flow width apart (gap fill fills
the gap it is in; its few scattered lines measured as sparse took the area the sparse blocks fill)."""


def _full_pitch(bl: BlockLines, role: Role) -> BlockLines:
    """Give a block of a solid role (:data:`_FULL`) the flow width as pitch when its lines measure sparse.

    Slicers print these roles at 100 %, so a measured spacing over :data:`~.regions.DENSE_PITCH` flow
    widths is not a spacing between neighbouring lines: Bambu Studio and OrcaSlicer write a single
    ring of internal solid infill along the walls around sparse infill (OrcaSlicer 2.3.1 P1S cube,
    layer 95: one loop, whose two sides 18 mm apart measured as its pitch; Bambu Studio A1 hook,
    layers 36-40).  Taken as sparse, the ring was closed over that pitch and covered the whole
    domain, leaving the sparse blocks no region.
    """
    if role in _FULL and not bl.dense:
        return BlockLines(bl.x0, bl.y0, bl.x1, bl.y1, bl.flow_width, bl.flow_width)
    return bl


def _full_kind_pitch(b: InfillBlock, kind: str) -> float:
    """The pitch of a block solid by its plastic: its flow width when its lines measure sparse.

    :func:`_full_pitch` does this for the roles slicers always print solid; a block of a sparse role
    is solid by its density alone (:data:`~.classify.SOLID_DENSITY`), known only once its region is.
    Cura at 100 % with a pattern of several line families per layer (grid: two, triangles,
    tri-hexagon, cubic: three) lays each family 2-3 flow widths apart, and the dominant family's
    spacing (:func:`~.pitch.estimate_pitch`) is not the spacing of neighbouring beads: taken as the
    new paths' pitch, it laid a third to a half of the slicer's volume, and every such block was kept.
    """
    if kind == "sparse" or not (np.isfinite(b.density) and b.density >= SOLID_DENSITY):
        return b.pitch
    if b.pitch <= DENSE_PITCH * b.flow_width:
        return b.pitch
    return b.flow_width


def _classified(layers: list[LayerGeometry]) -> list[LayerGeometry]:
    """Set every block's kind from its density and its exposure to the object's neighbouring layers."""
    from dataclasses import replace

    outlines = [g.outline for g in layers]
    out = []
    for i, g in enumerate(layers):
        below = outlines[i - 1] if i > 0 else None
        above = outlines[i + 1] if i + 1 < len(layers) else None
        islands = []
        for isl in g.islands:
            blocks = []
            for b in isl.blocks:
                down = exposed_fraction(b.region, below, b.bead_width) if i > 0 else 1.0
                up = exposed_fraction(b.region, above, b.bead_width)
                kind = classify(b.role, b.density, i == 0, down, up)
                blocks.append(replace(b, kind=kind, exposed_down=down, exposed_up=up,
                                      pitch=_full_kind_pitch(b, kind)))
            islands.append(replace(isl, blocks=tuple(blocks)))
        out.append(replace(g, islands=tuple(islands)))
    return out


def _check(layers: list[LayerGeometry], program: Program) -> None:
    """Every replaceable block's centre lines lie inside its region (within the stated tolerance).

    Blocks of the kinds always kept (gap fill, bridges, ironing, ...) are not checked: nothing fills
    their region (the replace region leaves out their footprint, made from their own beads), and gap
    fill between two perimeters (OrcaSlicer, Bambu Studio) lies outside the infill domain by design.
    """
    for g in layers:
        for isl in g.islands:
            for b in isl.blocks:
                tol = check_tolerance(b.flow_width)
                if b.replaceable and b.outside > tol:
                    line = int(program.blocks["start"][b.block_index]) + 1 if b.block_index >= 0 else 0
                    raise GeometryError(
                        f"layer {g.layer_index + 1} (z = {g.z:g} mm), object {g.object!r}: the {b.feature!r} "
                        f"block at line {line} runs {b.outside:.3f} mm outside the infill region derived for "
                        f"it (tolerance {tol:.3f} mm); the perimeters do not enclose the infill: re-slice "
                        "with closed perimeters, or report the file")
