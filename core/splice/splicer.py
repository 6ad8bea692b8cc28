"""Splice new infill into a slicer's G-code: replace chosen blocks, keep every other line exactly.

>>> from loadpath import gcode
>>> from loadpath.splice import BlockFill, SpliceOptions, splice
>>> program = gcode.read("examples/ohs.gcode")                       # doctest: +SKIP
>>> result = splice(program, [BlockFill(block=17, paths=paths, region=region)], options)  # doctest: +SKIP
>>> open("out.gcode", "wb").write(result.data)                        # doctest: +SKIP

For each :class:`BlockFill` the block's span (entering travel .. leaving wipe/retraction) and its
detached exit are rewritten by :func:`loadpath.splice.rewrite.rewrite_block` from a plan made by
:func:`loadpath.splice.plan.plan_block`; :meth:`Program.replace_lines` then builds the file, so every
line outside the replaced ranges stays byte for byte where it was.  Blocks that cannot be replaced
safely (a mode or tool change inside them) are kept and reported in :attr:`SpliceResult.skipped`.

Time and material in the footer: the time (distance / feedrate) of every replaced range is measured
before and after.  PrusaSlicer's footer lines (``; estimated printing time (...) = ``, ``; filament
used [mm] = ``, and its volume, weight and cost) are kept verbatim and followed by a line with
loadpath's updated value (``; estimated printing time after loadpath (normal mode) = ...``); Cura's
``;TIME:`` header line is followed by a comment with the change.  A run that counts its blocks with
the firmware's acceleration and jerk puts that figure in place of the time (:func:`retimed`).
``M73`` progress lines inside a replaced block are spread over the new block at the same fraction of
its length, so they stay in order and monotone.

(Over 400 lines: the options and result records, and the footer's time and filament notes,
belong to the one :func:`splice` call.)
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field, replace

import numpy as np
from loadpath._typing import Region
from loadpath.errors import SettingsError
from loadpath.gcode.model import Block, Program
from loadpath.gcode.rowindex import move_rows
from loadpath.splice.arcfit import ArcOptions, arcs_allowed
from loadpath.splice.beadruns import RunOptions, bead_runs
from loadpath.splice.emit import STYLES, Style
from loadpath.splice.flow import FlowModel
from loadpath.splice.plan import PlanOptions, plan_block
from loadpath.splice.rewrite import refusal, returns_to, rewrite_block
from loadpath.splice.travel import Motion, Retraction
from loadpath.toolpath import Path

__all__ = [
    "SpliceOptions",
    "BlockFill",
    "BlockReport",
    "SpliceResult",
    "splice",
    "block_feedrate",
    "block_height",
    "kinematic_time",
]


@dataclass(frozen=True)
class SpliceOptions:
    """Everything the splicer needs to know about the machine and the slicer's habits.

    Attributes
    ----------
    flow : FlowModel
    motion : Motion
        Travel speed and retraction.
    plan : PlanOptions
        Widths, links, volumetric limit, volume matching.
    runs : RunOptions
        Runs of one bead width (one ``;WIDTH:`` marker each) and the final simplification
        (:mod:`loadpath.splice.beadruns`).
    notes : bool
        Add the updated time / filament estimate after the slicer's footer lines.
    volume_tol : float or None
        A block whose new paths (after volume matching) would extrude more than this relative
        difference from the slicer's is kept as sliced and reported in ``skipped`` (the engine left
        too much of its region empty, or crowded it).  None: replace anyway.
    xy_decimals : int
        Decimals of X and Y in the new extrusion moves (the slicer writes 3, the default).  Not
        lowered by default: ``bench_printability.py``'s 40 % PrusaSlicer bar, swarm, predicted failure
        load (``loadpath compare``) 1.662x the slicer's at 3 / 5 decimals, 1.607x at 2 / 5, 1.657x at
        3 / 4, 1.544x at 2 / 4 (its grip end, where the bead ends decide), for 2 % fewer bytes there
        and 8-11 % on the solid parts.  Issue 17: at 2 a
        vertex moves by at most 0.007 mm (half of 0.01 mm on each axis), below one full step of
        an 80-100 step/mm axis and a sixth of the linked runs' simplification bound (0.045 mm), on
        both sides of the path at random where the chords' sag is all to one side; one byte less
        for each of X and Y on nine moves in ten.  (Counted against the runs' bound, it tightened
        that bound by 16 % and cost more vertices than the digits saved: example 881,501 ->
        877,529 bytes.)
    e_decimals : int
        Decimals of relative E words (the slicer writes 5, the default).  At 4 the E resolution is 0.0001 mm
        of filament, a thirtieth of one step of a 280 step/mm extruder; each move's rounding is
        carried to the next, so a path's filament is exact to 0.00005 mm.  Absolute E keeps 5.
    arcs : ArcOptions or None
        Runs of segments on a circle written as ``G2``/``G3`` (:mod:`loadpath.splice.arcfit`), in
        files whose settings allow arcs only (:func:`~loadpath.splice.arcfit.arcs_allowed`).
        None: never.
    """

    flow: FlowModel
    motion: Motion = Motion()
    plan: PlanOptions = PlanOptions()
    runs: RunOptions = RunOptions()
    notes: bool = True
    volume_tol: float | None = 0.03
    xy_decimals: int = 3
    e_decimals: int = 5
    arcs: ArcOptions | None = ArcOptions()


@dataclass(frozen=True)
class BlockFill:
    """New paths for one feature block.

    Attributes
    ----------
    block : int
        Row of ``Program.blocks``.
    paths : tuple of Path
        The new paths (reordered for printing unless ``PlanOptions.order`` is off).
    region : shapely Polygon or MultiPolygon, optional
        The block's replace region: links stay inside it and travels that leave it retract.
    flow_width : float, mm, optional
        Fixed flow width (sparse infill at the slicer's width); None: the paths' local pitch.
    nominal_pitch : float, mm, optional
        Pitch of printed links; default the median pitch of the paths.
    feedrate : float, mm/min, optional
        Default: the replaced block's own (:func:`block_feedrate`).
    simplified : bool
        The paths were already simplified with the splice's plan options (the pipeline does it once
        for all the layers that reuse them).
    volume_scale : float
        The block's new volume over the slicer's (1: the same plastic; the user's sparse fill over
        the slicer's when it was set, :mod:`loadpath.density`); volume matching and the checks aim
        at ``volume_scale`` times the slicer's volume.
    linked : bool
        The paths are linked runs (:mod:`loadpath.engines.linking`): simplified within
        :attr:`RunOptions.linked_resolution` (solid infill) or :attr:`RunOptions.sparse_resolution`
        (sparse: ``flow_width`` set) instead of ``resolution`` (:meth:`RunOptions.bound`).
    shared : bool
        The block is one of several in its island printing one unit's runs, and ``volume_scale``
        gives it its runs' share of their plastic (:func:`loadpath.pipeline.paths.share_volume`).
    comb : shapely Polygon or MultiPolygon, optional
        The island's part outline (:attr:`loadpath.geometry.Island.outline`): a travel between the
        slicer's walls and the region may step over the walls inside it where the file combs or
        avoids crossing perimeters (:func:`loadpath.splice.travel.route`).  None: only within
        :data:`~loadpath.splice.travel.SHORT_REACH` of the region.
    """

    block: int
    paths: tuple[Path, ...]
    region: Region | None = None
    flow_width: float | None = None
    nominal_pitch: float | None = None
    feedrate: float | None = None
    simplified: bool = False
    volume_scale: float = 1.0
    linked: bool = False
    shared: bool = False
    comb: Region | None = None


@dataclass(frozen=True)
class BlockReport:
    """What happened to one replaced block (filament in mm, lengths in mm, times in s)."""

    block: int
    layer: int
    feature: str
    object: str | None
    filament_old: float
    filament_new: float
    filament_model: float
    length_old: float
    length_new: float
    seconds_old: float
    seconds_new: float
    n_paths: int
    n_links: int
    n_travels: int
    n_retracts: int
    correction: float
    feedrate: float
    height: float
    width_min: float
    width_max: float
    volume_scale: float = 1.0

    @property
    def volume_ratio(self) -> float:
        """New over old extruded material."""
        return self.filament_new / self.filament_old if self.filament_old > 0 else float("nan")


@dataclass(frozen=True)
class SpliceResult:
    """The spliced file and what was done.

    Attributes
    ----------
    data : bytes
        The new file.
    edits : tuple of (start, stop, n_new_lines)
        Original line ranges replaced (half-open) and how many lines replaced each, in file order
        (including inserted notes: ``start == stop``).
    blocks : tuple of BlockReport
    skipped : tuple of (block, reason)
    seconds_delta : float, s
        Change of the kinematic print-time estimate.
    """

    data: bytes
    edits: tuple[tuple[int, int, int], ...]
    blocks: tuple[BlockReport, ...]
    skipped: tuple[tuple[int, str], ...] = ()
    seconds_delta: float = 0.0
    stats: dict = field(default_factory=dict)

    def output_ranges(self, program: Program, block: int) -> list[tuple[int, int]]:
        """Output lines ``[a, z)`` that replaced block ``block``'s span (and its detached exit)."""
        b = program.block(block)
        wanted = {(b.span_start, b.span_stop), (b.exit_start, b.exit_stop)}
        out, shift = [], 0
        for a, z, k in sorted(self.edits):
            if (a, z) in wanted and z > a:
                out.append((a + shift, a + shift + k))
            shift += k - (z - a)
        return out

    def line_map(self, n_lines: int) -> np.ndarray:
        """Output line of every original line, -1 for replaced lines; ``(n_lines,) int64``."""
        shift = np.zeros(n_lines + 1, dtype=np.int64)
        keep = np.ones(n_lines, dtype=bool)
        for start, stop, n_new in self.edits:
            keep[start:stop] = False
            shift[stop] += n_new - (stop - start)
        out = np.arange(n_lines, dtype=np.int64) + np.cumsum(shift)[:n_lines]
        return np.where(keep, out, -1)


def kinematic_time(moves: np.ndarray) -> float:
    """Sum of distance / feedrate over moves (E-only moves: filament distance), s; no acceleration."""
    if len(moves) == 0:
        return 0.0
    d = np.sqrt(
        (moves["x1"] - moves["x0"]) ** 2 + (moves["y1"] - moves["y0"]) ** 2 + (moves["z1"] - moves["z0"]) ** 2
    )
    d = np.where(d > 0, d, np.abs(moves["e"]))
    f = moves["f"]
    ok = np.isfinite(f) & (f > 0)
    return float(np.sum(d[ok] / f[ok]) * 60.0)


def _weighted_median(v: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(v)
    cw = np.cumsum(w[order])
    return float(v[order][np.searchsorted(cw, cw[-1] / 2)])


def _median_pitch(paths) -> float:
    """Median vertex pitch of the paths, mm (0 when there are none)."""
    return float(np.median(np.concatenate([p.pitch for p in paths]))) if paths else 0.0


def block_feedrate(program: Program, b: Block) -> float:
    """Return the block's extrusion feedrate (length-weighted median, with cooling slowdown), mm/min."""
    mv = program.moves[b.moves]
    mv = mv[mv["extrude"] & np.isfinite(mv["f"])]
    if len(mv) == 0:
        raise SettingsError(
            f"block {b.index} (layer {b.layer + 1}, {b.feature}) has no feedrate; "
            "the file sets no F before its extrusions"
        )
    return _weighted_median(mv["f"], np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"]) + 1e-12)


def block_height(program: Program, b: Block) -> float:
    """Bead height of the block's extrusions, mm (``;HEIGHT:``, else the layer height)."""
    mv = program.moves[b.moves]
    h = mv["height"][mv["extrude"]]
    h = h[np.isfinite(h)]
    if len(h) == 0:
        return float(program.layers[b.layer].height)
    return float(np.median(h))


def style_of(program: Program) -> Style:
    """Return the writing style of the file's marker family."""
    return STYLES.get(program.dialect.family, STYLES["prusa"])


def splice(
    program: Program, fills: Iterable[BlockFill], options: SpliceOptions, workers: int = 1
) -> SpliceResult:
    """Replace blocks with new paths (see the module docstring).

    Parameters
    ----------
    program : Program
    fills : iterable of BlockFill
        At most one per block.
    options : SpliceOptions
    workers : int
        Processes for the blocks (:func:`loadpath.procs.fork_map`: forked, they inherit the program
        and the fills; only each block's new text and report come back).  Each block's text depends
        on that block alone, so the result is the same bytes whatever the number of workers.

    Returns
    -------
    SpliceResult
    """
    global _WORK
    fills = sorted(fills, key=lambda f: f.block)
    seen = [f.block for f in fills]
    if len(set(seen)) != len(seen):
        raise SettingsError("a block was given new paths twice; give each block at most one BlockFill")
    plan_options = options.plan
    if plan_options.free_travel <= 0:  # the order prefers the travels the slicer would not retract
        r = options.motion.retraction
        free = float("inf") if r.only_when_crossing else r.before_travel
        plan_options = replace(plan_options, free_travel=free)
    from loadpath.procs import fork_map, spans
    from loadpath.splice import compiled

    if sum(len(p.points) for f in fills for p in f.paths) >= compiled.COMPILED_FROM:
        compiled.load()  # before the workers fork: they inherit the loops
    extruding = np.flatnonzero(program.moves["extrude"])  # where each block's next extrusion is
    _WORK = [(program, fills, options, plan_options, style_of(program), extruding)]
    try:
        # contiguous batches: a few hundred kB of text per result instead of a round trip per block
        done = fork_map(_splice_batch, spans(len(fills), workers, 8), workers)
    finally:
        _WORK = []
    edits: list[tuple[int, int, bytes]] = []
    reports, skipped = [], []
    for got in done:
        for block, new_edits, report, why in got:
            if why is not None:
                skipped.append((block, why))
                continue
            edits += new_edits
            reports.append(report)
    delta = sum(r.seconds_new - r.seconds_old for r in reports)
    dfil = sum(r.filament_new - r.filament_old for r in reports)
    if options.notes and reports:
        edits += _notes(program, delta, dfil, options.flow)
    edits.sort(key=lambda t: (t[0], t[1]))
    data = program.replace_lines(edits)
    nl = program.newline
    counted = tuple((a, z, new.count(nl) if nl == b"\r\n" else new.count(b"\n")) for a, z, new in edits)
    return SpliceResult(
        data=data, edits=counted, blocks=tuple(reports), skipped=tuple(skipped), seconds_delta=delta
    )


NO_PATHS = "no new path fits in its"
"""Why a block the engine laid nothing in is kept as sliced (the run's warnings group these)."""

OVERFILLED = 1.3
"""A block whose plastic is this many times a solid layer's over its region holds lines laid over
lines (CuraEngine 4.13 at 100 % printed four layers of a 4 mm lever at 192 %): the new paths, one
layer of them, fall short of it, and the reason says so instead of blaming the engine."""

ENGINE_COVERED = ": the engine covered too {} of the region"
"""Why the new paths of a kept block miss its volume, ``much`` or ``little`` filled in (the pipeline
names the pitch instead where the user set it)."""

_WORK: list[tuple] = []
"""What :func:`splice` hands to :func:`_splice_batch` (inherited by the forked workers, not pickled):
``(program, sorted fills, options, plan options, style, rows of the extruding moves)``."""


def _far_apart(fill: BlockFill) -> str:
    """`` at a mean pitch of 7.55 mm`` where a block of sparse lines got no path because its lines lie
    far apart (three flow widths or more), else ``""``.  PrusaSlicer's lightning infill at 15 % lays
    a chain link's lower layers at 7-8 mm: no path fits the link at one phase of the staggered
    copies, and "no new path fits in its 145.2 mm of bead" alone read like a bug."""
    if fill.shared or not (fill.flow_width and fill.nominal_pitch and fill.volume_scale > 0):
        return ""
    pitch = fill.nominal_pitch / fill.volume_scale  # the user's sparse fill lays volume_scale x the plastic
    return f"{MEAN_PITCH}{pitch:.3g} mm" if pitch >= 3.0 * fill.flow_width else ""


MEAN_PITCH = " at a mean pitch of "
"""How :data:`NO_PATHS` reasons name sparse lines set far apart (the pipeline names the user's pitch)."""


def _splice_batch(span: tuple[int, int]) -> list[tuple[int, list, BlockReport | None, str | None]]:
    """:func:`_splice_block` of the fills ``[a, z)`` of :data:`_WORK`."""
    program, fills, options, plan_options, style, extruding = _WORK[0]
    return [
        _splice_block(program, f, options, plan_options, style, extruding) for f in fills[span[0] : span[1]]
    ]


def next_extrusion(program: Program, line: int, extruding: np.ndarray) -> np.ndarray | None:
    """Where the slicer's first extrusion at or after ``line`` starts, ``(2,)`` mm (None: none follows).

    ``extruding``: the rows of ``program.moves`` that extrude, in order.  A replaced block's order
    weighs the travel from its last path to there (:func:`loadpath.splice.plan.plan_block`'s
    ``end``): the next feature starts there whatever the block does.
    """
    row = program.move_rows(line, line).start
    k = int(np.searchsorted(extruding, row))
    if k >= len(extruding):
        return None
    mv = program.moves[extruding[k]]
    return np.array([float(mv["x0"]), float(mv["y0"])])


def _splice_block(
    program: Program,
    fill: BlockFill,
    options: SpliceOptions,
    plan_options: PlanOptions,
    style: Style,
    extruding: np.ndarray | None = None,
) -> tuple[int, list[tuple[int, int, bytes]], BlockReport | None, str | None]:
    """One block's new text: ``(block, edits, report, None)``, or ``(block, [], None, why)`` when kept."""
    vol_area = options.flow.filament_area if options.flow.volumetric else None
    b = program.block(fill.block)
    why = refusal(program, b)
    if why is not None:
        return fill.block, [], None, why
    feed = fill.feedrate or block_feedrate(program, b)
    height = block_height(program, b)
    s0 = program.state_before(b.span_start)
    end = None
    if extruding is not None:
        end = returns_to(program, b)
        if end is None:
            end = next_extrusion(program, max(b.span_stop, b.exit_stop), extruding)
    plan = plan_block(
        fill.paths,
        np.array([s0.x, s0.y]),
        height,
        feed,
        options.flow,
        plan_options,
        region=fill.region,
        nominal_pitch=fill.nominal_pitch,
        flow_width=fill.flow_width,
        target_filament=b.e * fill.volume_scale,
        simplified=fill.simplified,
        end=end,
    )
    unit = fill.flow_width or fill.nominal_pitch or _median_pitch(fill.paths)
    ends = np.array([p.points[i] for p in fill.paths for i in (0, -1)]) if fill.paths else None
    # linked runs have their own simplification bound, solid or sparse (RunOptions.bound)
    runs = replace(options.runs, resolution=options.runs.bound(fill.linked, fill.flow_width is not None))
    plan = bead_runs(plan, options.flow, height, unit, options.plan.resolution, ends, runs)
    aim = b.e * fill.volume_scale
    whose = "slicer's volume" if fill.volume_scale == 1.0 else "volume of the sparse fill asked for"
    if fill.shared:
        whose = "share of the island's volume its runs take"
    if options.volume_tol is not None and aim > 0:
        if plan.filament <= 0:  # a sliver (PrusaSlicer's 0.6 mm solid bits), or lines set far apart
            return fill.block, [], None, f"{NO_PATHS} {b.length:.1f} mm of bead{_far_apart(fill)}"
        if abs(plan.filament / aim - 1) > options.volume_tol:
            solid = options.flow.e_for_area(fill.region.area * height) if fill.region is not None else 0.0
            if plan.filament < aim and solid > 0 and aim > OVERFILLED * solid:
                why = (
                    f"the slicer lays {aim / solid:.0%} of a solid layer's plastic in it (lines over "
                    "lines), more than one layer of new paths holds"
                )
                return fill.block, [], None, why
            return (
                fill.block,
                [],
                None,
                f"the new paths would extrude {plan.filament / aim:.0%} of the {whose}"
                + ENGINE_COVERED.format("much" if plan.filament > aim else "little"),
            )
    style = replace(style, path_xy_decimals=options.xy_decimals, e_decimals=options.e_decimals)
    arcs = None
    if options.arcs is not None and arcs_allowed(program.config):
        arcs = replace(options.arcs, chord=max(runs.resolution * unit - options.plan.resolution, 0.0))
    rw = rewrite_block(program, b, plan, fill.region, options.motion, style, vol_area, arcs, fill.comb)
    edits = [(b.span_start, b.span_stop, rw.span.encode("utf-8"))]
    old_rows = [move_rows(program, b.span_start, b.span_stop)]
    if rw.exit is not None:
        edits.append((b.exit_start, b.exit_stop, rw.exit.encode("utf-8")))
        old_rows.append(move_rows(program, b.exit_start, b.exit_stop))
    secs_old = sum(kinematic_time(program.moves[r]) for r in old_rows)
    report = BlockReport(
        block=fill.block,
        layer=b.layer,
        feature=b.feature,
        object=b.object,
        filament_old=b.e,
        filament_new=plan.filament,
        filament_model=plan.raw_filament,
        length_old=b.length,
        length_new=plan.length,
        seconds_old=secs_old,
        seconds_new=rw.seconds,
        n_paths=plan.n_paths,
        n_links=plan.n_links,
        n_travels=rw.n_travels,
        n_retracts=rw.n_retracts,
        correction=plan.correction,
        feedrate=feed,
        height=height,
        width_min=plan.stats.get("width_min", float("nan")),
        width_max=plan.stats.get("width_max", float("nan")),
        volume_scale=fill.volume_scale,
    )
    return fill.block, edits, report, None


# ---------------------------------------------------------------------------------------------- notes

_TIME_RE = re.compile(r"^; estimated printing time \((.+?)\) = (.+?)\s*$")
_FIL_MM_RE = re.compile(r"^; filament used \[mm\] = ([0-9.]+)\s*$")
_CURA_TIME_RE = re.compile(r"^;TIME:([0-9.]+)\s*$")
_FIL_MORE_RE = re.compile(r"^; ((?:total )?filament (?:used|cost))( \[(?:g|cm3)\])? = ([0-9.]+)\s*$")
_DURATION_RE = re.compile(r"(\d+)\s*([dhms])")


def parse_duration(text: str) -> float | None:
    """Seconds of a PrusaSlicer duration (``"1d 2h 47m 41s"``), None when unreadable."""
    parts = _DURATION_RE.findall(text)
    if not parts:
        return None
    mult = {"d": 86400, "h": 3600, "m": 60, "s": 1}
    return float(sum(int(v) * mult[u] for v, u in parts))


def format_duration(seconds: float) -> str:
    """``"1d 2h 47m 41s"`` style, as PrusaSlicer writes it."""
    s = max(0, int(round(seconds)))
    d, s = divmod(s, 86400)
    h, s = divmod(s, 3600)
    m, s = divmod(s, 60)
    out = [f"{d}d"] * bool(d) + [f"{h}h"] * bool(d or h) + [f"{m}m"] * bool(d or h or m) + [f"{s}s"]
    return " ".join(out)


def _notes(program: Program, delta: float, dfil: float, flow: FlowModel) -> list[tuple[int, int, bytes]]:
    """Lines with loadpath's updated estimates, inserted after the slicer's own: print time
    (:func:`_time_notes`) and filament, the filament's length and, where the slicer states them, its
    volume, weight and cost scaled with it."""
    nl = program.newline
    out = _time_notes(program, delta)
    if program.dialect.family == "cura":
        return out
    scale = None
    for i in range(program.print_end, program.n_lines):
        text = program.line(i)
        m = _FIL_MM_RE.match(text)
        if m:
            mm = float(m.group(1))
            scale = (mm + dfil) / mm if mm > 0 else None
            note = f"; filament used after loadpath [mm] = {mm + dfil:.2f}"
            out.append((i + 1, i + 1, note.encode() + nl))
            continue
        m = _FIL_MORE_RE.match(text)
        if m and scale is not None:
            note = f"; {m.group(1)} after loadpath{m.group(2) or ''} = {float(m.group(3)) * scale:.2f}"
            out.append((i + 1, i + 1, note.encode() + nl))
    return sorted(out)


def _time_notes(program: Program, delta: float) -> list[tuple[int, int, bytes]]:
    """The print-time lines of :func:`_notes`: PrusaSlicer's estimates plus ``delta`` seconds, or a
    line after CuraEngine's ``;TIME:`` saying how much the replaced infill changes it."""
    nl = program.newline
    out = []
    cura = program.dialect.family == "cura"
    lo, hi = (0, min(program.n_lines, 64)) if cura else (program.print_end, program.n_lines)
    sign = "+" if delta >= 0 else "-"
    for i in range(lo, hi):
        text = program.line(i)
        m = _TIME_RE.match(text)
        if m:
            old = parse_duration(m.group(2))
            if old is not None:
                new = format_duration(old + delta)
                note = f"; estimated printing time after loadpath ({m.group(1)}) = {new}"
                out.append((i + 1, i + 1, note.encode() + nl))
            continue
        if cura and _CURA_TIME_RE.match(text):
            note = (
                f";loadpath: ;TIME: above is the slicer's estimate; the replaced infill changes it by about "
                f"{sign}{format_duration(abs(delta))}"
            )
            out.append((i + 1, i + 1, note.encode() + nl))
            break
    return out


def retimed(program: Program, result: SpliceResult, seconds: float) -> SpliceResult:
    """``result`` with the print-time change ``seconds`` in place of the splice's own.

    The splice adds up distance over feedrate (no acceleration), the old blocks' and the new; the
    verdict's counts (:func:`loadpath.printability.replaced_blocks`) time both with the firmware's
    acceleration and jerk.  On a lever whose swarm infill retracts 1440 times against the slicer's
    54, the splice said +2.6 min and the counts +9.6 (a planner of PrusaSlicer's kind, +11.8): the
    run states the counts' figure, in ``seconds_delta`` and in the footer's time lines.
    """
    data = result.data
    for (_, _, old), (_, _, new) in zip(
        _time_notes(program, result.seconds_delta), _time_notes(program, seconds), strict=True
    ):
        data = data.replace(old, new, 1)
    return replace(result, data=data, seconds_delta=float(seconds))
