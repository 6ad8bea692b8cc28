"""What gets replaced: units of work (the replaced blocks of one kind in one island of one layer).

The table "What is replaced, what is kept" of interface.md decides here:

- only blocks whose kind (:mod:`loadpath.geometry.classify`) is in the ``replace`` option: by
  default internal solid infill; the first layer and exposed skins are ``bottom`` / ``top`` and are
  kept unless asked; bridges, gap fill, ironing, perimeters, skirt, supports, wipe tower always kept;
- objects the load case does not apply to (``object =``) are passed through;
- vase mode and sequential printing are passed through with a warning (:func:`passthrough_reason`).

A :class:`Unit` is what one engine run fills: its region is the union of its blocks' regions in the
island, its pitch the slicer's (the median over its blocks) unless the user set one.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any
from dataclasses import dataclass, field, replace

import numpy as np
import shapely
from loadpath._typing import Region
from loadpath.gcode.model import climbing
from loadpath.geometry import InfillBlock, PrintGeometry
from loadpath.options import user_pitch

__all__ = [
    "Unit",
    "check_engine_budget",
    "select_units",
    "passthrough_reason",
    "purge_blocks",
    "unreliable_blocks",
    "FIXED_WIDTH_KINDS",
    "sparse_pitch",
    "slicer_overlap",
    "with_overlap",
]

FIXED_WIDTH_KINDS = ("sparse",)
"""Kinds printed at the slicer's own bead width (the paths' pitch is the sparse line spacing); the
other kinds fill their region completely, with the flow width following the local pitch."""


@dataclass(frozen=True)
class Unit:
    """The replaced blocks of one kind in one island of one layer of one object.

    Attributes
    ----------
    object : str
        Object name (:attr:`loadpath.geometry.ObjectGeometry.name`).
    layer : int
        Index into ``Program.layers``.
    island : int
    kind : str
        ``"solid"``, ``"sparse"``, ``"top"`` or ``"bottom"``.
    region : Polygon or MultiPolygon
        Union of the blocks' regions in this island, mm.
    blocks : tuple of InfillBlock
    pitch : float, mm
        Path pitch: the user's, else the slicer's for these blocks.
    flow_width : float, mm
        The slicer's flow width of these blocks.
    height : float, mm
        Layer height.
    z : float, mm
        Top of the layer.
    overlap : float, mm
        How far the slicer's own beads of these blocks reach past the region's edge into the
        perimeters (:func:`slicer_overlap`); 0 until :func:`with_overlap` measured it.
    engine_region : Polygon or MultiPolygon or None
        What the engine fills: the region grown by ``overlap`` towards the walls (None: the region).
    outline : Polygon or None
        The island's part outline (:attr:`loadpath.geometry.Island.outline`): where the splice's
        travels may cross the walls to reach the region.
    """

    object: str
    layer: int
    island: int
    kind: str
    region: Region = field(repr=False)
    blocks: tuple[InfillBlock, ...] = field(repr=False)
    pitch: float
    flow_width: float
    height: float
    z: float
    overlap: float = 0.0
    engine_region: Region | None = field(default=None, repr=False)
    outline: Region | None = field(default=None, repr=False)

    @property
    def fill_region(self) -> Region:
        """The area the new paths fill: ``engine_region`` if set, else ``region``."""
        return self.region if self.engine_region is None else self.engine_region

    @property
    def z_mid(self) -> float:
        """Middle of the layer, mm (where the stress field of a 3D analysis is cut)."""
        return self.z - self.height / 2

    @property
    def fixed_width(self) -> bool:
        """Printed at the slicer's bead width (sparse infill) rather than at the local pitch."""
        return self.kind in FIXED_WIDTH_KINDS


def check_engine_budget(units: Sequence[Unit]) -> None:
    """Stop when a unit's fill region has more pitch cells than :data:`loadpath.budget.ENGINE_CELLS`.

    The engines' path samples, agents and QP unknowns grow with ``area / pitch^2``; counted here,
    before the FEA, so an implausible pitch stops the run with its layer instead of exhausting memory.
    """
    from loadpath import budget

    for u in units:
        area = float(u.fill_region.area)
        budget.check(area / u.pitch**2, budget.ENGINE_CELLS,
                     f"layer {u.layer + 1} (z = {u.z:g} mm), object {u.object!r}",
                     f"pitch cells for the path engine ({area:,.0f} mm2 of {u.kind} infill at a {u.pitch:.3g} mm "
                     "pitch)", "set a larger --pitch (the slicer's own is 0.4-0.5 mm for solid infill), or check "
                     "the file's infill")


SPIRAL_MOVES = 20
"""Extrusions that climb in Z while they print (at least this many, and 1 % of all): a spiral vase,
whatever the file's settings say (CuraEngine writes none).  Of 277 files of the 2026-12-07 sweeps of
new parts and slicer settings and of ``benchmarks/bench_printability.py``, the four vases climb on
32 of 1195, 78 of 914, 288 of 624 and 359 of 924 extrusions, every other file on none."""


def passthrough_reason(
    config: Mapping[str, str], cura_settings: Mapping[str, object] | None = None, moves: Any = None
) -> str | None:
    """Why the whole file must be passed through unchanged (vase mode, sequential printing), or None.

    ``moves``: the program's moves (:attr:`loadpath.gcode.Program.moves`), to tell a spiral vase by
    its climbing walls where the settings do not say (:data:`SPIRAL_MOVES`).
    """
    cfg = {k.lower(): str(v).strip() for k, v in config.items()}
    cura = {k.lower(): str(v).strip().lower() for k, v in (cura_settings or {}).items()}
    spiral = False
    if moves is not None and len(moves):
        ext = moves["extrude"]
        climbs = int(np.count_nonzero(ext & climbing(moves)))
        spiral = climbs >= max(SPIRAL_MOVES, 0.01 * np.count_nonzero(ext))
    if cfg.get("spiral_vase") == "1" or cura.get("magic_spiralize") == "true" or spiral:
        return "vase mode (spiral vase): the part has no infill to replace"
    if cfg.get("complete_objects") == "1" or cura.get("print_sequence") == "one_at_a_time":
        return (
            "sequential printing (one object after another): objects are printed to full height one by one, "
            "which loadpath does not handle"
        )
    return None


def purge_blocks(program) -> set[int]:
    """Infill blocks that take the purge after a tool change (PrusaSlicer ``wipe_into_infill``).

    With ``wipe_into_infill = 1`` the slicer purges the new filament into the infill printed first
    after a tool change; those blocks are kept (interface.md: purges are kept out of the replaced
    region).  Returns block indices.
    """
    if str(program.config.get("wipe_into_infill", "0")).split(",")[0].strip() != "1":
        return set()
    from loadpath.gcode.words import T

    cmd = program.state.cmd
    changes = np.flatnonzero((cmd >= T) & (cmd < T + 10_000))
    starts = program.blocks["start"]
    out = set()
    for line in changes:
        k = int(np.searchsorted(starts, line, side="right"))
        while k < len(starts):
            b = program.block(k)
            if b.role.is_infill:
                out.add(k)
                break
            if b.role.name != "WIPE_TOWER":
                break
            k += 1
    return out


def _median(values: Iterable[float], weights: Iterable[float]) -> float:
    v = np.asarray(list(values), dtype=float)
    w = np.asarray(list(weights), dtype=float)
    order = np.argsort(v)
    cw = np.cumsum(w[order])
    return float(v[order][np.searchsorted(cw, cw[-1] / 2)]) if len(v) else float("nan")


def unreliable_blocks(geo: PrintGeometry) -> dict[int, float]:
    """Blocks whose own lines leave the region derived for them (open perimeters, ...): block -> mm.

    The geometry's tolerance is :func:`loadpath.geometry.regions.check_tolerance` of the block's flow
    width.  Such blocks are kept as sliced instead of failing the whole file.
    """
    from loadpath.geometry.regions import check_tolerance

    out: dict[int, float] = {}
    for obj in geo.objects:
        for lg in obj.layers:
            for isl in lg.islands:
                for b in isl.blocks:
                    if b.outside > check_tolerance(b.flow_width):
                        out[b.block_index] = max(out.get(b.block_index, 0.0), float(b.outside))
    return out


def unreliable_reason(dist: float) -> str:
    """Why :func:`unreliable_blocks` names a block whose lines leave its region by ``dist`` mm (a
    block with no region of its own, ``inf``: other blocks of the layer cover its area)."""
    if math.isinf(dist):
        return "it has no region of its own: other blocks cover its area"
    return f"its lines run {dist:.2f} mm outside the infill region found from the perimeters"


def select_units(
    geo: PrintGeometry,
    objects: Sequence[str],
    replace: Sequence[str],
    pitch: float | None = None,
    exclude: Iterable[int] = (),
) -> list[Unit]:
    """Return the units of work of the named objects, in file order.

    Parameters
    ----------
    geo : PrintGeometry
    objects : sequence of str
        Names of the objects the load case applies to.
    replace : sequence of str
        Kinds to replace.
    pitch : float, mm, optional
        The user's pitch; default each unit's slicer pitch.  For sparse infill that is the pitch
        that lays the slicer's plastic per area (:func:`sparse_pitch`) where it is denser than
        the spacing of the slicer's lines.
    exclude : iterable of int
        Blocks to keep whatever their kind (purges).
    """
    kinds = tuple(replace)
    skip = set(exclude)
    pitch = user_pitch(pitch)
    out = []
    for obj in geo.objects:
        if obj.name not in objects:
            continue
        for lg in obj.layers:
            for isl in lg.islands:
                for kind in kinds:
                    blocks = tuple(
                        b
                        for b in isl.blocks
                        if b.kind == kind and not b.region.is_empty and b.block_index not in skip
                    )
                    if not blocks:
                        continue
                    region = (
                        shapely.union_all([b.region for b in blocks]) if len(blocks) > 1 else blocks[0].region
                    )
                    if region.is_empty or region.area <= 0:
                        continue
                    w = [b.length for b in blocks]
                    fw = _median([b.flow_width for b in blocks], w)
                    p = pitch if pitch is not None else _median([b.pitch for b in blocks], w)
                    if pitch is None and kind in FIXED_WIDTH_KINDS:
                        p = sparse_pitch(p, region.area, sum(w), fw)
                    out.append(
                        Unit(
                            obj.name,
                            lg.layer_index,
                            isl.index,
                            kind,
                            region,
                            blocks,
                            float(p),
                            fw,
                            float(lg.height),
                            float(lg.z),
                            outline=isl.outline,
                        )
                    )
    out.sort(key=lambda u: (u.layer, min(b.block_index for b in u.blocks)))
    return out


TOUCHING = 1.5
"""Sparse lines measured closer than this many flow widths apart touch their neighbours: the slicer
draws each line several times side by side (CuraEngine's ``infill_multiplier``), and the measured
spacing is between the copies (:func:`sparse_pitch`)."""


def sparse_pitch(line_pitch: float, area: float, length: float, flow_width: float | None = None) -> float:
    """Pitch of new sparse infill at the slicer's density: its plastic per area, mm.

    Sparse infill keeps the slicer's bead width, so its density is its extruded length per area.
    The slicer prints more than its lines' spacing says: PrusaSlicer anchors each line along the
    perimeters (``infill_anchor``), Cura may add lines under the skins' edges.  On a narrow part
    that is a fifth or more of the plastic (a 16 mm wide bar sliced by PrusaSlicer 2.5 at 20 %:
    815 mm of extrusion against 659 mm of lines at its 2.035 mm spacing), more than the flow
    correction may make up, so the new paths are laid at ``area / length`` instead, never
    sparser than the slicer's lines, unless those touch (:data:`TOUCHING`): CuraEngine at 20 % with
    ``infill_multiplier = 2`` draws its lines in pairs 0.4 mm apart, and taken as the pitch that
    spacing laid ten times the plastic; every block was kept (325 % of the slicer's volume).

    Parameters
    ----------
    line_pitch : float, mm
        Spacing of the slicer's lines.
    area : float, mm^2
        The region the blocks fill.
    length : float, mm
        Their extruded length in it.
    flow_width : float, mm, optional
        Their flow width (without it, lines are never taken as touching).
    """
    if length <= 0 or area <= 0:
        return line_pitch
    if flow_width and line_pitch < TOUCHING * flow_width:
        return float(area / length)
    return float(min(line_pitch, area / length))


def _extruding_rows(program, unit: Unit) -> list[np.ndarray]:
    """Indices of the extruding rows of ``program.moves`` in each of the unit's blocks, one array per
    block (indices, not the rows: the callers read two or three of their columns)."""
    extrude = program.moves["extrude"]
    out = []
    for b in unit.blocks:
        a, z = (int(program.blocks[k][b.block_index]) for k in ("move_start", "move_stop"))
        out.append(np.arange(a, z)[extrude[a:z]])
    return out


def slicer_overlap(program, unit: Unit) -> float:
    """How far the slicer's beads of a unit's blocks reach past the region's edge, mm.

    Slicers run infill into the innermost perimeter for a good bond (PrusaSlicer's
    ``infill_overlap``, 25 % in the MK3S profiles; Cura's ``skin_overlap`` / ``infill_overlap``).
    Measured, not read from the settings, so every slicer and version is handled alike: the ends
    of the blocks' extrusions that lie within a flow width of the region's edge sit, in the median,
    ``d`` mm inside it; their beads (flow width ``w``) reach ``w / 2 - d`` past it.  PrusaSlicer 2.5
    at 0.45 mm solid infill: ends 0.123 mm inside, 0.10 mm past the edge.

    Returns
    -------
    float, mm
        In ``[0, w / 2]``; 0 when fewer than 8 ends lie near the edge.
    """
    m = program.moves
    ends = []
    for rows in _extruding_rows(program, unit):
        if len(rows):
            ends.append(np.column_stack([m["x0"][rows], m["y0"][rows]]))
            ends.append(np.column_stack([m["x1"][rows], m["y1"][rows]]))
    if not ends:
        return 0.0
    pts = np.concatenate(ends)
    w = unit.flow_width
    d = shapely.distance(unit.region.boundary, shapely.points(pts))
    inside = shapely.contains_xy(unit.region, pts[:, 0], pts[:, 1])
    d = np.where(inside, d, -d)
    near = np.abs(d) < w
    if np.count_nonzero(near) < 8:
        return 0.0
    return float(np.clip(0.5 * w - np.median(d[near]), 0.0, 0.5 * w))


def island_domains(geo: PrintGeometry) -> dict[tuple[str, int, int], Region]:
    """Every island's infill domain, keyed ``(object name, layer index, island index)`` as a unit
    names its island: what :func:`with_overlap` and :func:`growth_shares` grow the units within."""
    return {
        (obj.name, lg.layer_index, isl.index): isl.domain
        for obj in geo.objects
        for lg in obj.layers
        for isl in lg.islands
    }


def with_overlap(units: Sequence[Unit], program, geo: PrintGeometry, workers: int = 1) -> list[Unit]:
    """Units whose engine region reaches as far into the perimeters as the slicer's own beads did.

    The region is grown by :func:`slicer_overlap` towards the walls only (not into the blocks that
    are kept), so the engine's outermost beads and path ends meet the perimeters as the slicer's
    did instead of stopping at the perimeters' flow edge, and no further than the slicer's plastic
    tiles (:func:`growth_shares`).  Fixed-width (sparse) units are left as they are.  ``workers``:
    processes for the units (:func:`loadpath.procs.fork_map`, contiguous batches; each unit's region
    depends on that unit and its object's share alone: the same regions; the 1000-layer specimen's
    998 units took 1.4-2.8 s of one core).
    """
    global _WORK
    domains = island_domains(geo)
    from loadpath.procs import fork_map, spans

    share = growth_shares(units, program, domains, geo.filament_diameter, workers)
    _WORK = [(units, program, domains, share)]
    try:
        grown = [g for got in fork_map(_overlap_batch, spans(len(units), workers, 4), workers) for g in got]
    finally:
        _WORK = []
    return [u if g is None else replace(u, overlap=g[0], engine_region=g[1]) for u, g in zip(units, grown, strict=True)]


_WORK: list[tuple] = []
"""What :func:`with_overlap` hands to :func:`_overlap_batch` (inherited by forked workers, not
pickled): ``(units, program, island domains, each unit's growth share)``."""


def _overlap_batch(span: tuple[int, int]) -> list[tuple[float, Any] | None]:
    """:func:`_grown` of the units ``[a, z)`` of :data:`_WORK`."""
    units, program, domains, share = _WORK[0]
    return [_grown(units[i], program, domains, share[i]) for i in range(*span)]


def plastic_area(program, unit: Unit, diameter: float) -> float:
    """The area the slicer's plastic of a unit's blocks tiles at the layer height, mm².

    Solid infill's flow width is its line spacing (:func:`loadpath.geometry.flow_widths`), so the
    filament the blocks extrude in the unit's island, over the layer height, is the area their beads
    cover; the new beads, matched to that volume (:mod:`loadpath.splice.plan`), cover no more.
    """
    m = program.moves
    near = unit.region.buffer(unit.flow_width, quad_segs=4)  # a block may print other islands too
    vol = 0.0
    for rows in _extruding_rows(program, unit):
        mid = 0.5 * (m["x0"][rows] + m["x1"][rows]), 0.5 * (m["y0"][rows] + m["y1"][rows])
        vol += float(np.sum(m["e"][rows][shapely.contains_xy(near, *mid)]))
    return vol * math.pi * diameter**2 / 4 / unit.height if unit.height > 0 else 0.0


SHARE_STEP = 0.05
"""Growth shares are taken down to a multiple of this (:func:`growth_shares`), so that a re-slice
whose plastic moves by round-off keeps the same engine regions (and the cache's paths)."""


def growth_shares(
    units: Sequence[Unit], program, domains: dict, diameter: float, workers: int = 1
) -> list[float]:
    """The share of the slicer's bead reach each unit's engine region grows by, in [0, 1].

    The slicer's beads reach into the walls only at their line ends, while a region grown all round
    is filled edge to edge: the same plastic spread over more area prints every bead narrower than
    its spacing.  On CuraEngine's 100 % files (lines 0.24 mm into the walls, a region grown 0.20 mm
    all round) the tension bar's beads were printed at 0.965 of their spacing, a slit of void between
    every two.  So the growth stops where the region would outgrow the blocks' plastic
    (:func:`plastic_area`; a band about linear in its width), measured on the first unit the slicer
    grew of each group of alike regions (:func:`loadpath.geometry.group_regions`) and taken down to
    a multiple of :data:`SHARE_STEP`, one share for the group: layers alike keep engine regions alike
    (one engine run), though their plastic differs a little (PrusaSlicer's +-45 degree layers: 0.77
    and 0.88 of the reach fit).  The groups' first units are measured in ``workers`` processes
    (a part whose every layer differs has a group per layer), the next ones only where the slicer
    did not grow the first.
    """
    global _FIT_WORK
    from loadpath.geometry import group_regions
    from loadpath.procs import fork_map, spans

    solid = [i for i, u in enumerate(units) if not u.fixed_width]
    keys = [(units[i].object, units[i].kind) for i in solid]
    labels = group_regions([units[i].region for i in solid], keys=keys)
    members: dict[int, list[int]] = {}
    for i, lab in zip(solid, labels, strict=True):
        members.setdefault(lab, []).append(i)
    share = [1.0] * len(units)
    left = dict(members)  # each group's members not measured yet
    while left:
        reps = [(lab, idx[0]) for lab, idx in left.items()]
        _FIT_WORK = [([units[i] for _, i in reps], program, domains, diameter)]
        try:
            fits = [f for got in fork_map(_fit_batch, spans(len(reps), workers, 4), workers) for f in got]
        finally:
            _FIT_WORK = []
        nxt = {}
        for (lab, _), fit in zip(reps, fits, strict=True):
            if fit is not None:
                for i in members[lab]:
                    share[i] = math.floor(fit / SHARE_STEP + 1e-9) * SHARE_STEP
            elif len(left[lab]) > 1:  # not grown by the slicer (a first layer over the skin): the next
                nxt[lab] = left[lab][1:]
        left = nxt
    return share


_FIT_WORK: list[tuple] = []
"""What :func:`growth_shares` hands to :func:`_fit_batch` (inherited by forked workers):
``(units to measure, program, island domains, filament diameter)``."""


def _fit_batch(span: tuple[int, int]) -> list[float | None]:
    """:func:`_fit` of the units ``[a, z)`` of :data:`_FIT_WORK`."""
    units, program, domains, diameter = _FIT_WORK[0]
    return [_fit(u, program, domains, diameter) for u in units[slice(*span)]]


def _fit(u: Unit, program, domains: dict, diameter: float) -> float | None:
    """The share of the slicer's reach whose band the unit's plastic still tiles (1: the whole reach),
    or None where the slicer did not grow it."""
    o = slicer_overlap(program, u)
    if o <= 0:
        return None
    extra = _grow(u, domains, o).area - u.region.area
    room = plastic_area(program, u, diameter) - u.region.area
    return 1.0 if extra <= room else max(room, 0.0) / extra


def _grow(u: Unit, domains: dict, by: float):
    """``u``'s region grown by ``by`` mm towards the walls only (not into the island's kept blocks)."""
    grown = u.region.buffer(by, join_style="mitre", mitre_limit=2.0)
    domain = domains.get((u.object, u.layer, u.island))
    if domain is not None:
        kept = domain.difference(u.region)
        grown = grown.difference(kept) if not kept.is_empty else grown
        grown = grown.intersection(domain.buffer(by, join_style="mitre", mitre_limit=2.0))
    return shapely.make_valid(grown) if not grown.is_valid else grown


def _grown(u: Unit, program, domains: dict, share: float = 1.0) -> tuple[float, Any] | None:
    """``(overlap, engine region)`` of one unit (:func:`with_overlap`), None when it stays as it is:
    grown by ``share`` of :func:`slicer_overlap` (:func:`growth_shares`)."""
    o = 0.0 if u.fixed_width else share * slicer_overlap(program, u)
    if o < 1e-3:
        return None
    grown = _grow(u, domains, o)
    parts = [g for g in shapely.get_parts(grown) if g.geom_type == "Polygon" and g.area > 0]
    return o, (shapely.union_all(parts) if parts else u.region)
