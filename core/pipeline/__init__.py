"""The whole run: G-code in, stress-aligned G-code out.

>>> from loadpath import gcode, loadcase
>>> from loadpath.pipeline import PipelineOptions, run
>>> program = gcode.read("examples/ohs.gcode")                                   # doctest: +SKIP
>>> case = loadcase.read("examples/ohs.toml")                                     # doctest: +SKIP
>>> result = run(program, case, PipelineOptions(), splice_options)               # doctest: +SKIP
>>> result.data                     # the new G-code text, checked; nothing is written here  # doctest: +SKIP

Stages (each timed in :attr:`PipelineResult.times`):

``geometry``
    layer regions per object, island and block (:func:`loadpath.geometry.layer_geometry`);
``loadcase``
    the load case applied to the objects' bodies (:func:`loadpath.loadcase.resolve`): a part whose
    layers share one outline is one prism and is solved in 2D once;
``fea``
    one analysis per body (:func:`loadpath.fea.analyze`);
``paths``
    one engine run per distinct unit (:mod:`loadpath.pipeline.paths`), in worker processes, reused on
    identical layers; every other one of those prints a staggered copy (the engine lays it itself
    from seeds half a pitch on, :func:`~loadpath.pipeline.paths.lays_phase`: the swarm and the
    streamlines' default mode; otherwise the paths are shifted sideways by half a pitch); a layer
    whose region is its representative's within rounding (:func:`~loadpath.pipeline.paths.reuses`)
    prints the representative's linked runs, any other is cut to its own region and linked in it;
``splice``
    the new paths written into the slicer's G-code (:func:`loadpath.splice.splice`), the blocks in
    the same worker processes (each block's text depends on that block alone: the same bytes);
``check``
    the result re-read and checked against the original (:func:`loadpath.splice.verify.check_output`,
    from the new bytes, a few hundred thousand lines at a time: no second Program is built); a
    failure raises
    :class:`~loadpath.errors.SpliceError` and nothing is returned.

Files with nothing to replace, and vase-mode or sequential prints, come back unchanged with a warning.

(Over 400 lines: :func:`run` and the records it returns; its stages are the modules named above.)
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
import shapely
from loadpath import options
from loadpath.engines import Machine
from loadpath.engines.linking import link_paths
from loadpath.errors import SpliceError
from loadpath.field import RotatedField
from loadpath.gcode import Program, parse
from loadpath.density import DensityOptions, density_field, solid_share
from loadpath.pipeline.paths import (
    Job,
    assign,
    clip_to,
    lies_in,
    job_key,
    job_near_key,
    lays_phase,
    plan_jobs,
    reuses,
    RELAYS,
    length_target,
    relay_factor,
    run_jobs,
    stagger,
    share_volume,
    volume_scale,
)
from loadpath.pipeline.units import (
    Unit,
    check_engine_budget,
    passthrough_reason,
    purge_blocks,
    select_units,
    unreliable_blocks,
    unreliable_reason,
    with_overlap,
)
from loadpath.splice import BlockFill, SpliceOptions, SpliceResult, splice
from loadpath.splice.splicer import ENGINE_COVERED
from loadpath.splice.plan import PlanOptions, simplify
from loadpath.splice.verify import SpliceCheck, check_output
from loadpath.tolerances import TOL
from loadpath.toolpath import Path, Toolpaths

__all__ = ["PipelineOptions", "PipelineResult", "EngineRun", "run", "STAGES"]

STAGES = ("parse", "geometry", "loadcase", "fea", "paths", "splice", "check", "write")
"""Stage names, in order (``parse`` and ``write`` are timed by the caller)."""

Progress = Callable[[str, int, int], None]

SPARSE_EXACT = 200
"""The exact links' node count on a layer of sparse infill, every engine
(:attr:`loadpath.engines.linking.LinkOptions.exact`; 0: the greedy linking alone; sparse layers are
solved by the linear relaxation, below, which takes no branch-and-bound node, so any count above 0
lays the same links), in files that retract travels inside the infill (PrusaSlicer's
``retract_before_travel``): where they do not (Cura's combing) a run fewer saves no retraction,
and the links' plastic is taken from the lines at the slicer's mass (CuraEngine 40 % files of
``bench_printability.py``: failure load 2.330 -> 1.860x the slicer's on the bar, 1.796 -> 1.539x on
the gyroid bar).  Solid infill takes its engine's own
(:attr:`loadpath.engines.registry.Engine.linking`).

Sparse layers are solved by the linear relaxation (``LinkOptions.exact_integers = 0``): in integers,
HiGHS took 0.3-5 s a layer on the 30 % gyroid gusset of ``bench_latency.py`` (31-41 paths, the 5 s
guard reached; its first run 15-18 s -> 22-28 s) whatever the node count (10, 50 or 200), for 27
runs on its 12 sparse layers where the relaxation leaves 29 in 1.05 s and the greedy linking 32 in
0.43 s.  Measured (``benchmarks/printability_results.md``, thirty-fourth round): on the 20
PrusaSlicer files of ``bench_sparse.py`` the retractions per layer are lower on 8 and higher on none
(mean ratio to the slicer's 1.43 -> 1.34), travel 1.27 -> 1.19; the failure load lower on 6 and
higher on 3 (geometric mean 2.231 -> 2.178x; the shelf at gyroid 40 % 1.705 -> 1.258x: more
plastic in links is less in lines at the slicer's mass), stiffness 1.651x as before.
``bench_printability.py``, PrusaSlicer 40 %, retractions: cantilever 48 -> 32, L-bracket 44 -> 32,
taper 37 -> 33, gyroid bar 18 -> 14, bar 20 as before."""


@dataclass(frozen=True)
class PipelineOptions:
    """What to replace and how (the toolpath part of :class:`loadpath.plugin.settings.Settings`).

    Attributes
    ----------
    engine : str
        A registered engine (:data:`loadpath.engines.NAMES`).
    engine_params : mapping
        Engine parameters (``{"K": 5.0}`` for the swarm).
    sparse_engine : str or None
        The engine for sparse infill (:func:`loadpath.engines.for_sparse` resolves the user's
        ``sparse_engine``); None: ``engine``.
    sparse_engine_params : mapping
        Its parameters.
    solid_first : str or None
        An engine tried first on solid infill (:func:`loadpath.engines.first_on_solid`): its paths
        are kept unless its run reports ``stats["give_way"]``, and ``engine`` lays that job instead
        (the level sets give way where a jump of the stress direction cuts the layer: a bending
        part's neutral axis).  None: ``engine`` lays all solid infill.
    solid_first_params : mapping
        Its parameters (``{"give_way": True}``).
    pitch : float or None, mm
        None: each unit's slicer pitch.
    principal : str
        ``"max_abs"``, ``"min_abs"``, ``"tensile"``, ``"compressive"``, ``"alternate"`` (``max_abs``
        on even layers, ``min_abs`` on odd ones) or ``"cross"`` (``max_abs`` turned by
        ``+cross_angle`` on even layers, ``-cross_angle`` on odd ones: families that brace each other).
    cross_angle : float, degrees
    replace : tuple of str
    stagger : bool
    workers : int
        Processes for the engine runs.
    check : bool
        Re-read and check the result (:mod:`loadpath.splice.verify`).
    volume_tol : float
        Largest relative difference of a block's volume accepted by the check.
    overlap : bool
        Grow each unit's region by the slicer's own infill-perimeter overlap before the engine
        fills it (:func:`loadpath.pipeline.units.with_overlap`).
    link : bool
        Link each job's paths (and its staggered copy) end to end into continuous runs
        (:mod:`loadpath.engines.linking`), whatever the engine.
    density : DensityOptions or None
        Where replaced sparse infill puts its plastic (:mod:`loadpath.density`): dense where the
        part works, at the slicer's mass unless ``density.fill`` is set.  None or criterion
        ``"uniform"``: the slicer's uniform density.
    """

    engine: str = options.field("engine").default
    engine_params: Mapping[str, Any] = field(default_factory=dict)
    sparse_engine: str | None = None
    sparse_engine_params: Mapping[str, Any] = field(default_factory=dict)
    solid_first: str | None = None
    solid_first_params: Mapping[str, Any] = field(default_factory=dict)
    pitch: float | None = options.field("pitch").default
    principal: str = options.field("principal").default
    cross_angle: float = options.field("cross_angle").default
    replace: tuple[str, ...] = options.field("replace").default
    stagger: bool = options.field("stagger").default
    workers: int = 1
    check: bool = True
    volume_tol: float = 0.03
    overlap: bool = True
    link: bool = options.field("link").default
    density: DensityOptions | None = None

    def __post_init__(self) -> None:
        # the toolpath options' own checks (loadpath.options), so a caller that builds these
        # directly gets the same one-line errors as the command line and the load case
        for name in ("engine", "principal", "replace", "stagger"):
            options.convert(options.field(name), getattr(self, name), f"PipelineOptions.{name}")
        for name in ("sparse_engine", "solid_first"):
            if getattr(self, name) is not None:
                options.convert(options.field("engine"), getattr(self, name), f"PipelineOptions.{name}")
        if options.user_pitch(self.pitch) is not None:
            options.convert(options.field("pitch"), self.pitch, "PipelineOptions.pitch")

    def engine_for(self, unit: Unit, first: bool = False) -> tuple[str, Mapping[str, Any]]:
        """The engine that lays ``unit`` and its parameters: ``sparse_engine`` for sparse infill;
        ``first``: ``solid_first`` for solid infill, when set."""
        if unit.fixed_width and self.sparse_engine is not None:
            return self.sparse_engine, self.sparse_engine_params
        if first and self.solid_first is not None and not unit.fixed_width:
            return self.solid_first, self.solid_first_params
        return self.engine, self.engine_params


@dataclass
class EngineRun:
    """One engine run and the layers that print its paths.

    Attributes
    ----------
    job : Job
    units : list of Unit
        The units that use the paths (the first is the representative).
    paths : Toolpaths
        As the engine made them (before staggering).
    seconds : float
        Engine time.
    staggered : list of bool
        Per unit, whether it printed the staggered copy.
    shifted : tuple of Path
        The staggered copy as printed (simplified); empty when no unit printed one.
    shifted_by_engine : bool
        Whether the engine laid the staggered copy itself (the swarm or the streamlines' default
        mode, from seeds half a pitch on: :func:`loadpath.pipeline.paths.lays_phase`) rather than
        the paths being shifted sideways (:func:`loadpath.pipeline.paths.stagger`).
    printed : tuple of Path
        The paths as printed on the first layer (simplified, linked into runs); empty when they
        are the engine's.
    links : dict
        What the linking did (:func:`loadpath.engines.linking.link_paths` stats, first layer and
        staggered copy summed), empty when off.
    engine : str
        The engine that laid the paths (:meth:`PipelineOptions.engine_for`).
    """

    job: Job
    units: list[Unit]
    paths: Toolpaths
    seconds: float
    staggered: list[bool]
    shifted: tuple[Path, ...] = ()
    shifted_by_engine: bool = False
    printed: tuple[Path, ...] = ()
    links: dict = field(default_factory=dict)
    engine: str = ""

    @property
    def layers(self) -> list[int]:
        """Program layer indices printing these paths."""
        return [u.layer for u in self.units]


@dataclass(frozen=True)
class PipelineResult:
    """Everything a run produced.

    Attributes
    ----------
    data : bytes
        The new G-code text (the input's bytes when nothing was replaced).
    program : Program
        The input.
    splice : SpliceResult or None
    check : SpliceCheck or None
    jobs : tuple of EngineRun
    analyses : dict of str -> Analysis
        FEA per object name.
    geometry : PrintGeometry or None
    times : dict of str -> float, s
    warnings : tuple of str
    passthrough : str or None
        Why the file came back unchanged.
    fea_keys : dict of str -> str
        Object name -> its analysis's key in the cache (:func:`loadpath.cache.fea_key`; empty
        without a cache): what the verdict's prediction is kept under.
    counts : tuple or None
        The verdict's counts of the replaced blocks (:func:`loadpath.printability.verdict_counts`'
        answer), when they were made beside the check (:func:`_check_and_count`); None: not made yet.
    """

    data: bytes
    program: Program
    splice: SpliceResult | None = None
    check: SpliceCheck | None = None
    jobs: tuple[EngineRun, ...] = ()
    analyses: dict = field(default_factory=dict)
    geometry: Any = None
    times: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    passthrough: str | None = None
    fea_keys: dict = field(default_factory=dict)
    counts: tuple | None = None

    @property
    def changed(self) -> bool:
        """Whether any block was replaced."""
        return self.splice is not None and bool(self.splice.blocks)

    @cached_property
    def output(self) -> Program | None:
        """The output parsed (None when nothing was replaced), on first use only (the report's).

        A whole Program of a large output is several times the file (1.1 GB for 4.6M lines); the
        check reads the bytes without it (:func:`loadpath.splice.verify.check_output`).
        """
        return parse(self.data, strict=False) if self.splice is not None else None


class _Clock:
    def __init__(self, times: dict[str, float]) -> None:
        self.times = times
        self.t = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.times[stage] = self.times.get(stage, 0.0) + now - self.t
        self.t = now


def run(
    program: Program,
    loadcase,
    options: PipelineOptions,
    splice_options: SpliceOptions,
    progress: Progress | None = None,
    cura_settings: Mapping[str, Any] | None = None,
    analyze: Callable[..., Any] | None = None,
    cache: Any = None,
) -> PipelineResult:
    """Run the pipeline on a parsed program (see the module docstring).

    Parameters
    ----------
    program : Program
    loadcase : loadpath.loadcase.LoadCase
    options : PipelineOptions
    splice_options : SpliceOptions
    progress : callable, optional
        ``progress(stage, done, total)``.
    cura_settings : mapping, optional
        Cura's settings (for vase mode / sequential printing detection).
    analyze : callable, optional
        ``analyze(resolved_body, pitch=...) -> Analysis`` instead of :func:`loadpath.fea.analyze`
        (e.g. one with a fixed mesh).
    cache : loadpath.cache.Cache, optional
        Keeps each body's analysis (:func:`loadpath.cache.fea_key`) and each engine run's paths
        (:func:`loadpath.pipeline.paths.job_key`) on disk; what is found there is loaded instead of
        solved or run again (a re-export with other speeds reuses everything).  Not used with
        ``analyze``.

    Raises
    ------
    LoadCaseError, GeometryError, MeshingError, SolverError, SettingsError
        From the stages.
    SpliceError
        The result failed its check.

    (Over 120 lines: the stages in order, each a call into its module -- parse, geometry, load case,
    FEA, engine runs, splice, check -- with the clock and progress between them.)
    """
    from loadpath import fea, geometry
    from loadpath.loadcase import resolve

    if analyze is not None:  # the keys cannot tell what another analyze depends on
        cache = None
    times: dict[str, float] = {}
    clock = _Clock(times)
    warnings: list[str] = []
    tell = progress or (lambda stage, done, total: None)

    reason = passthrough_reason(program.config, cura_settings, program.moves)
    if reason:
        return PipelineResult(
            program.data,
            program,
            times=times,
            warnings=(f"passed through unchanged: {reason}",),
            passthrough=reason,
        )

    tell("geometry", 0, 1)
    geo = geometry.layer_geometry(program, check=False, cache=cache, workers=options.workers)  # failing blocks: kept, below
    clock.lap("geometry")
    resolved = resolve(loadcase, geo.bodies())
    names = [rb.name for rb in resolved]
    warnings.extend(w for rb in resolved for w in rb.held_loads())
    for obj in geo.objects:
        if obj.name not in names:
            warnings.append(
                f"object {obj.name!r} is not in the load case (object = {loadcase.object!r}): "
                "passed through unchanged"
            )
    purges = purge_blocks(program)
    if purges:
        warnings.append(
            f"{len(purges)} infill block(s) take the purge after a tool change (wipe into infill): kept"
        )
    unsure = unreliable_blocks(geo)
    for block, dist in unsure.items():
        b = program.block(block)
        if geo_kind(geo, block) in options.replace:
            warnings.append(
                f"layer {b.layer + 1}, {b.feature}: kept as sliced ({unreliable_reason(dist)})"
            )
    units = select_units(geo, names, options.replace, options.pitch, exclude=purges | set(unsure))
    if options.overlap:
        units = with_overlap(units, program, geo, options.workers)
    check_engine_budget(units)  # before the FEA: a unit too big for the engines stops the run now
    clock.lap("loadcase")
    if not units:
        why = _nothing_to_replace(geo, names, options.replace)
        return PipelineResult(
            program.data, program, geometry=geo, times=times, warnings=(*warnings, why), passthrough=why
        )

    analyses = {}
    fea_keys: dict[str, str] = {}
    for k, rb in enumerate(resolved):
        tell("fea", k, len(resolved))
        pitches = [u.pitch for u in units if u.object == rb.name]
        pitch = float(np.median(pitches)) if pitches else None
        analyses[rb.name], fea_keys[rb.name] = _analysis(rb, pitch, analyze or fea.analyze, cache)
    tell("fea", len(resolved), len(resolved))
    clock.lap("fea")

    kind_of = {rb.name: rb.analysis for rb in resolved}
    fields: dict[tuple, Any] = {}

    def field_of(u: Unit, principal: str):
        key = (u.object, "2d" if kind_of[u.object] == "2d" else round(u.z_mid, 6), principal)
        if key not in fields:
            base, _, turn = principal.partition("@")
            f = analyses[u.object].field(u.z_mid, base)
            fields[key] = RotatedField(f, np.radians(float(turn))) if turn else f
        return fields[key]

    def principal_of(u: Unit) -> str:
        if options.principal == "alternate":
            return "max_abs" if u.layer % 2 == 0 else "min_abs"
        if options.principal == "cross":  # +-angle about the max-|sigma| direction, layer by layer
            return f"max_abs@{options.cross_angle if u.layer % 2 == 0 else -options.cross_angle:g}"
        return options.principal

    jobs = plan_jobs(units, field_of, principal_of, lambda u: kind_of[u.object])
    dens = options.density
    if dens is not None and (dens.criterion != "uniform" or dens.fill is not None):
        # "uniform" with a sparse fill set: an even field at that fill (unset: the slicer's pitch)
        nu = float(loadcase.material.poissons_ratio)
        shares = {o.name: solid_share(o) for o in geo.objects} if options.density.criterion == "stack" else {}
        jobs = [
            with_density(j, _density_of(j, options, shares), nu) if j.unit.fixed_width else j for j in jobs
        ]
    # the engine lays the staggered copy of a run of identical layers itself, from seeds half a
    # pitch on (option ``phase``): a whole layer again, where shifting the paths sideways and
    # clipping them left a poorer one (stiffness benchmark, share of the model's ceiling gain:
    # swarm, bracket 0.67 -> 0.83, specimen 0.79 -> 0.83; streamlines' default mode, bracket
    # 0.63 -> 0.83, specimen 0.77 -> 0.78).  The swarm's spacing pulls the copy part of the way
    # back onto the first one's paths (specimen: median 0.23 pitch apart instead of 0.5); the
    # streamlines' copy is a median 0.47 pitch off on the specimen, 0.29 on the bracket (curved
    # field, gap-filling pieces).  Which engines do this: lays_phase.
    # solid infill laid first by options.solid_first, where set; a job whose run gives way (and its
    # staggered copy) goes back to options.engine (below)
    gave_way: set[int] = set()

    def pick(j: Job) -> tuple[str, Mapping[str, Any]]:
        return options.engine_for(j.unit, first=id(j) not in gave_way)

    phased = (
        [k for k, j in enumerate(jobs) if len(j.units) > 1 and lays_phase(*pick(j))]
        if options.stagger
        else []
    )
    copies = [
        Job(jobs[k].unit, jobs[k].principal, jobs[k].input, jobs[k].units, {"phase": 0.5}) for k in phased
    ]
    retry = splice_options.plan.max_correction
    machine = Machine(
        nozzle=splice_options.plan.nozzle_diameter,
        width_range=tuple(float(w) for w in splice_options.plan.width_range),
    )

    def engine_runs(todo: list[Job], factors: list[float]) -> list[tuple[Toolpaths, float]]:
        picked = [pick(j) for j in todo]
        keys = near = None
        if cache is not None:
            args = []
            for j, (name, params), f in zip(todo, picked, factors, strict=True):
                fid = _field_id(fea_keys[j.unit.object], kind_of[j.unit.object], j.unit, j.principal)
                args.append((j, name, params, fid, retry, f))
            keys, near = [job_key(*a) for a in args], [job_near_key(*a) for a in args]
        return run_jobs(
            todo,
            [name for name, _ in picked],
            [dict(params) for _, params in picked],
            options.workers,
            lambda done, total: tell("paths", done, total),
            length_retry=retry,
            machine=machine,
            cache=cache,
            keys=keys,
            pitch_factor=factors,
            near_keys=near,
        )

    results = engine_runs(jobs + copies, [1.0] * (len(jobs) + len(copies)))
    shifted = {k: tp for k, (tp, _) in zip(phased, results[len(jobs) :], strict=True)}
    results = results[: len(jobs)]
    back = [k for k in range(len(jobs)) if results[k][0].stats.get("give_way")]
    if back:
        back_phased = [k for k in back if k in phased]  # their staggered copies are run again too
        again_of = [copies[phased.index(k)] for k in back_phased]
        gave_way.update(id(j) for j in [*(jobs[k] for k in back), *again_of])
        got = engine_runs([jobs[k] for k in back] + again_of, [1.0] * (len(back) + len(again_of)))
        for k, res in zip(back, got[: len(back)], strict=True):
            cut = results[k][0].stats.get("cut_mm")
            res[0].stats["gave_way"] = {"engine": options.solid_first, "cut_mm": cut}
            results[k] = res
        for k, res in zip(back_phased, got[len(back) :], strict=True):
            shifted[k] = res[0]
    ran_by = [pick(j)[0] for j in jobs]
    clock.lap("paths")

    r = splice_options.motion.retraction  # the splicer's own rule for a travel it may leave primed
    free_hop = float("inf") if r.only_when_crossing else float(r.before_travel)
    field_ids = [  # what names each job's field in the links' keys (None: sampled there)
        _field_id(fea_keys[j.unit.object], kind_of[j.unit.object], j.unit, j.principal)
        if fea_keys.get(j.unit.object) else None
        for j in jobs
    ]
    job_results, fills = _fills(
        units, jobs, results, options, splice_options.plan, shifted, cache, free_hop=free_hop,
        field_ids=field_ids, engines=ran_by,
    )
    # a sparse run whose linked layers still miss the slicer's plastic by more than the flow
    # correction takes back would be kept as sliced: each such layer (a job's first layer, its
    # staggered copy) is laid again at a closer (or, when its links made it too long, a wider)
    # pitch, up to RELAYS times (relay_factor), everything linked again each time (the other jobs'
    # links come from the cache), and the laying closest to the slicer's length is kept
    tried: dict[tuple[int, int], list[tuple[float, float]]] = {}  # (job, layer) -> (factor, length)
    laid: dict[tuple[int, int], dict[float, Any]] = {}  # (job, layer) -> factor -> engine result
    now: dict[tuple[int, int], float] = {}

    def relink(todo: Mapping[tuple[int, int], float], runs: Mapping[tuple[int, int], Any] | None = None):
        first = sorted(i for i, k in todo if k == 0)
        copy = sorted(i for i, k in todo if k == 1)
        if runs is None:
            got = engine_runs(
                [jobs[i] for i in first] + [copies[phased.index(i)] for i in copy],
                [todo[(i, 0)] for i in first] + [todo[(i, 1)] for i in copy],
            )
            runs = dict(zip([(i, 0) for i in first] + [(i, 1) for i in copy], got, strict=True))
            for i in first:
                runs[(i, 0)][0].stats["pitch_factor_after_links"] = todo[(i, 0)]
        for (i, k), res in runs.items():
            if k == 0:
                results[i] = res
            else:
                shifted[i] = res[0] if isinstance(res, tuple) else res
        now.update(todo)
        return _fills(
            units, jobs, results, options, splice_options.plan, shifted, cache, free_hop=free_hop,
            field_ids=field_ids, engines=ran_by,
        )

    for relay in range(RELAYS + 1):
        todo: dict[tuple[int, int], float] = {}
        for i, er in enumerate(job_results):
            target = length_target(jobs[i])
            if not target:
                continue
            layers = [er.printed or er.paths.paths] + ([er.shifted] if er.shifted and i in shifted else [])
            for k, printed in enumerate(layers):
                key, f = (i, k), now.get((i, k), 1.0)
                tried.setdefault(key, []).append((f, sum(p.length for p in printed)))
                laid.setdefault(key, {})[f] = results[i] if k == 0 else shifted[i]
                nf = relay_factor(tried[key], target, retry) if relay < RELAYS else None
                if nf is not None:
                    todo[key] = nf
        if not todo:
            break
        job_results, fills = relink(todo)
    # the laying closest to the slicer's length of each layer laid again (not always the last)
    best = {
        key: min(ts, key=lambda t, n=length_target(jobs[key[0]]): abs(t[1] / n - 1.0))[0]
        for key, ts in tried.items()
        if len(ts) > 1
    }
    back = {key: f for key, f in best.items() if f != now.get(key, 1.0)}
    if back:
        job_results, fills = relink(back, {key: laid[key][f] for key, f in back.items()})
    clock.lap("paths")
    fills = share_volume(fills, units, lambda b: program.block(b).e)
    sres = splice(program, fills, splice_options, workers=options.workers)
    fills, sres = _whole_units(program, fills, units, sres, splice_options, options.workers)
    sres = replace(sres, skipped=tuple(_at_pitch_asked(sres.skipped, options.pitch)))
    warnings.extend(_kept_as_sliced(program, sres.skipped))
    clock.lap("splice")
    tell("splice", 1, 1)

    check = counts = None
    if options.check:
        from loadpath.memory import trim

        trim()  # the splice's temporaries (each block's text, joined into the output) are freed
        regions = {f.block: f.region for f in fills if f.region is not None}
        check, counts = _check_and_count(
            program, sres, options.workers,
            lambda workers: check_output(
                program,
                sres.data,
                sres,
                volume_tol=options.volume_tol,
                regions=regions,
                retract_length=splice_options.motion.retraction.length,
                workers=workers,
            ),
        )
        trim()  # the pieces' arrays, before the verdict copies the output to put its line in
        if check.problems:
            raise SpliceError(
                f"the new G-code failed its check ({len(check.problems)} problem(s); first: "
                f"{check.problems[0]}); please report this with the file"  # the files' fate: the caller says
            )
    clock.lap("check")
    return PipelineResult(
        sres.data, program, sres, check, tuple(job_results), analyses, geo, times, tuple(warnings),
        fea_keys={k: v for k, v in fea_keys.items() if v}, counts=counts,
    )


def _nothing_to_replace(geo: Any, names: Sequence[str], asked: Sequence[str]) -> str:
    """Why a run replaced nothing, and what the user can ask for instead: the replaceable kinds of
    infill the load case's objects do have (none: a vase, or 0 % infill without solid layers)."""
    from loadpath.geometry.classify import REPLACEABLE

    have = {
        b.kind
        for o in geo.objects if o.name in names
        for lg in o.layers
        for isl in lg.islands
        for b in isl.blocks
    }
    other = [k for k in REPLACEABLE if k in have and k not in asked]
    head = (
        f"nothing to replace: no infill of the kind(s) {', '.join(asked)} in the objects the load case "
        "applies to"
    )
    if not other:
        return f"{head}, nor of any other kind loadpath replaces (a vase, or 0 % infill with no solid layers)"
    it = "it" if len(other) == 1 else "them"
    kinds = _toml_list([*asked, *other])
    return f"{head}; they have {', '.join(other)}: choose {it} with replace (e.g. replace = {kinds})"


def _toml_list(kinds: Sequence[str]) -> str:
    return "[" + ", ".join(f'"{k}"' for k in kinds) + "]"


_SIDE: list[Callable[[], Any]] = []
"""What :func:`_side_nth` calls in a forked worker (set by :func:`_check_and_count` before it forks)."""


def _side_nth(k: int) -> Any:
    return _SIDE[k]()


def _check_and_count(
    program: Program, sres: SpliceResult, workers: int, check: Callable[[int], SpliceCheck]
) -> tuple[SpliceCheck, tuple | None]:
    """The splice check, and beside it in a second process the verdict's counts of the replaced blocks.

    ``check(workers)`` reads the output.  The counts (:func:`loadpath.printability.replaced_blocks`)
    are mostly a parse of the whole output (0.4 s of a 100-layer file's repeated run), which the
    verdict would otherwise make after the check.  Side by side when there are two workers, a block
    was replaced and the output is within the verdict's line budget, the check then on one core;
    else the check alone on every worker (the verdict counts later, as before, or not at all over
    its budget).  Only the check's problems and the counts cross processes.
    """
    from loadpath.printability import VERDICT_LINES, replaced_blocks
    from loadpath.procs import fork_map, forks

    if not (forks(workers, 2) and sres.blocks and sres.data.count(b"\n") <= VERDICT_LINES):
        return check(workers), None
    _SIDE[:] = [
        lambda: check(1),
        lambda: (replaced_blocks(program, parse(sres.data, strict=False), sres), ""),
    ]
    try:
        got, counts = fork_map(_side_nth, [0, 1], 2)
    finally:
        _SIDE.clear()
    return got, counts


def _whole_units(
    program: Program,
    fills: list[BlockFill],
    units: Sequence[Unit],
    sres: SpliceResult,
    splice_options: SpliceOptions,
    workers: int,
) -> tuple[list[BlockFill], SpliceResult]:
    """A unit whose blocks share their runs prints whole or as sliced: ``(fills, splice result)``.

    Its blocks print one set of runs (:func:`loadpath.pipeline.paths.share_volume`), each the runs
    whose middle it holds; where the splice kept one of them as sliced (a bead width at its bound:
    a plate with a boss at PrusaSlicer 100 %, one block of 63 layers' units), its siblings' runs lay
    beside that block's own lines and their share of the unit lies in its region.  Those siblings
    are kept as sliced too, the file spliced again without them (only then), each with a warning.
    """
    kept = {k: why for k, why in sres.skipped}
    shared = {f.block for f in fills if f.shared}
    with_kept: dict[int, int] = {}
    for u in units:
        ids = [b.block_index for b in u.blocks]
        gone = [i for i in ids if i in kept and i in shared]
        for i in ids:
            if gone and i not in kept:
                with_kept[i] = gone[0]
    if not with_kept:
        return fills, sres
    fills = [f for f in fills if f.block not in with_kept]
    again = splice(program, fills, splice_options, workers=workers)
    extra = tuple(
        (i, f"the {program.block(k).feature} beside it, which shares its runs, was kept as sliced: {kept[k]}")
        for i, k in sorted(with_kept.items())
    )
    return fills, replace(again, skipped=tuple(sorted((*again.skipped, *extra))))


_COVERED = re.compile(re.escape(ENGINE_COVERED).replace(r"\{\}", "(much|little)") + "$")


def _at_pitch_asked(skipped: Sequence[tuple[int, str]], pitch: float | None) -> list[tuple[int, str]]:
    """The splice's reasons for the blocks it kept, where the user set the pitch: a volume the new
    paths miss then comes from that pitch, not from the engine (``--pitch 0.1`` on a 0.45 mm solid
    infill: 197 % of the slicer's plastic, every block kept, "the engine covered too much")."""
    if not pitch:
        return list(skipped)
    from loadpath.splice.splicer import MEAN_PITCH, NO_PATHS

    fix = f" at the pitch asked for ({pitch:g} mm; unset, the slicer's pitch lays the slicer's plastic)"
    asked = f" at the pitch asked for ({pitch:g} mm)"  # --pitch 50: no path fits a 3 mm wide part
    return [
        (k, why.split(MEAN_PITCH)[0] + asked if why.startswith(NO_PATHS) else _COVERED.sub(fix, why))
        for k, why in skipped
    ]


def _kept_as_sliced(program: Program, skipped: Sequence[tuple[int, str]], most: int = 3) -> list[str]:
    """The run's warnings for the blocks the splice kept as sliced: one per block, but where more
    than ``most`` were kept for the same reason, one line for them all.

    The slivers no new path fits in (:data:`loadpath.splice.splicer.NO_PATHS`: a 1000-layer
    PrusaSlicer specimen has 18 solid bits of 0.6 mm) name the longest; blocks whose reason differs
    only in its percentages (the volume a thin wall's paths would extrude: an angle bracket's 25 mm
    wall at CuraEngine 20 % kept 56 of them, each its own warning) give their range.
    """
    from loadpath.splice.splicer import MEAN_PITCH, NO_PATHS

    def reason(why: str) -> str:
        return NO_PATHS if why.startswith(NO_PATHS) else re.sub(r"\d+%", "#%", why, count=1)

    kept = [(program.block(k), why) for k, why in skipped]
    groups: dict[str, list[tuple[Any, str]]] = {}
    for b, why in kept:
        groups.setdefault(reason(why), []).append((b, why))
    out = [
        f"layer {b.layer + 1}, {b.feature}: kept as sliced ({why})"
        for b, why in kept
        if len(groups[reason(why)]) <= most
    ]
    for key, members in groups.items():
        if len(members) <= most:
            continue
        layers = sorted({b.layer + 1 for b, _ in members})
        shown = ", ".join(map(str, layers[:8])) + (f" and {len(layers) - 8} more" if len(layers) > 8 else "")
        if key == NO_PATHS:
            longest = max(b.length for b, _ in members)
            mark = " at the pitch asked"
            asked = next((why[why.index(mark) :] for _, why in members if mark in why), "")
            far = sorted(float(w.split(MEAN_PITCH)[1].split()[0]) for _, w in members if MEAN_PITCH in w)
            if far and not asked:  # lines set far apart: their mean pitches
                lo, hi = f"{far[0]:.3g}", f"{far[-1]:.3g}"
                asked = f"{MEAN_PITCH}{lo} mm" if lo == hi else f" at mean pitches of {lo}-{hi} mm"

            out.append(
                f"{len(members)} blocks kept as sliced, no new path fits in them{asked} (at most "
                f"{longest:.1f} mm of the slicer's bead each; layers {shown})"
            )
            continue
        shares = sorted(int(v) for _, why in members for v in re.findall(r"(\d+)%", why)[:1])
        if shares:  # one reason, its first percentage apart: their range
            span = f"{shares[0]}%" if shares[0] == shares[-1] else f"{shares[0]}-{shares[-1]}%"
            key = key.replace("#%", span, 1)
        out.append(f"{len(members)} blocks kept as sliced ({key}; layers {shown})")
    return out


def _analysis(rb, pitch: float | None, analyze: Callable[..., Any], cache) -> tuple[Any, str]:
    """Return a body's analysis (from the cache when it holds it, else solved and kept) and its key.

    A body whose slabs' outlines lie within ``TOL.region_reuse_mm`` of a kept analysis's
    (:func:`near_body`; the rest of :func:`loadpath.cache.fea_key` the same) takes that analysis
    and its key, so that the paths and predictions kept under it serve this run too: PrusaSlicer
    2.5 on all its threads moves a part's perimeters by micrometres from one slice to the next.
    """
    import dataclasses

    if cache is None:
        return analyze(rb, pitch=pitch), ""
    from loadpath.cache import fea_key, fea_near_key
    from loadpath.fea import Analysis

    key, near = fea_key(rb, pitch), fea_near_key(rb, pitch)
    hit = cache.get("fea", key)
    if not isinstance(hit, Analysis):
        for kept, outlines in cache.near("near-fea", near):
            if near_body(outlines, rb):
                hit = cache.get("fea", kept)
                if isinstance(hit, Analysis):
                    key = kept
                    break
    if isinstance(hit, Analysis):
        return dataclasses.replace(hit, resolved=rb, _cache={}), key
    a = analyze(rb, pitch=pitch)
    cache.put("fea", key, dataclasses.replace(a, _cache={}))
    cache.keep_near("near-fea", near, key, [shapely.to_wkb(slab.outline) for slab in rb.body.slabs])
    return a, key


def near_body(outlines: object, rb, tol: float = TOL.region_reuse_mm) -> bool:  # type: ignore[no-untyped-def]
    """Whether a kept analysis's slab outlines (WKB, :func:`_analysis`) lie within ``tol`` of the
    body's, slab by slab (:func:`reuses`)."""
    slabs = rb.body.slabs
    if not (isinstance(outlines, list) and len(outlines) == len(slabs)):
        return False
    return all(isinstance(w, bytes) and reuses(s.outline, shapely.from_wkb(w), tol)
               for w, s in zip(outlines, slabs, strict=True))


def _field_id(fea_key: str, kind: str, unit: Unit, principal: str) -> str:
    """Name of the stress field a unit's paths follow (its analysis, its cut, the principal stress)."""
    cut = "2d" if kind == "2d" else f"{unit.z_mid:.6f}"
    return f"{fea_key} {cut} {principal}"
def _density_of(job: Job, options: PipelineOptions, shares: Mapping[str, float]) -> DensityOptions:
    """The density options of one job: ``"stack"`` takes its object's solid share (``shares``, object
    name -> :func:`loadpath.density.solid_share`) and, with ``principal = "alternate"``, the family of
    lines the job lays (:mod:`loadpath.density`)."""
    d = options.density
    assert d is not None
    if d.criterion != "stack":
        return d
    family = None
    if options.principal == "alternate":
        family = "major" if job.principal == "max_abs" else "minor"
    return replace(d, solid_share=shares.get(job.unit.object, 0.0), family=family)


def with_density(job: Job, density: DensityOptions, poissons_ratio: float) -> Job:
    """The job with the density field of its region (:func:`loadpath.density.density_field`).

    The field is scaled to the unit's own fill (its slicer pitch), or to ``density.fill`` with the
    job's pitch rescaled to that fill, so each layer keeps the plastic the slicer gave it; a
    ``"stack"`` field of two alternating families moves plastic between the two (their pair keeps
    it), and the job's pitch follows its own mean.
    """
    u, inp = job.unit, job.input
    df = density_field(inp.field, inp.region, u.flow_width, inp.pitch, density, poissons_ratio)
    pitch = df.base_pitch if (density.fill is not None or density.family is not None) else inp.pitch
    return replace(job, input=replace(inp, density=df, pitch=pitch))


def geo_kind(geo, block: int) -> str | None:
    """Return the geometry's kind of a block (None when it is in no island)."""
    for obj in geo.objects:
        for lg in obj.layers:
            for isl in lg.islands:
                for b in isl.blocks:
                    if b.block_index == block:
                        return b.kind
    return None


def _simplified(paths, plan: PlanOptions, cache=None) -> tuple[Path, ...]:
    """Simplify paths once (every layer that prints them would otherwise do it again).

    With a ``cache``: kept under the paths' exact bytes, the three tolerances and the code (the
    splicer's sources included, :func:`loadpath.cache.source_stamp`).
    """
    key = None
    if cache is not None:
        from loadpath.cache import code_stamp, digest, source_stamp

        parts: list[bytes | str] = ["simplified", code_stamp(), source_stamp("splice")]
        parts.append(repr((float(plan.resolution), float(plan.pitch_resolution), float(plan.min_segment))))
        for p in paths:
            parts += [p.kind, np.ascontiguousarray(p.points, dtype=float).tobytes()]
            parts.append(np.ascontiguousarray(p.pitch, dtype=float).tobytes())
        key = digest(parts)
        hit = cache.get("simplified", key)
        if isinstance(hit, tuple):
            return hit
    out = _simplify_paths(paths, plan)
    if key is not None:
        cache.put("simplified", key, out, evict=False)
    return out


def _simplify_paths(paths, plan: PlanOptions) -> tuple[Path, ...]:
    """:func:`_simplified` without the cache."""
    simple = simplify(
        [(p.points, p.pitch) for p in paths], plan.resolution, plan.pitch_resolution, plan.min_segment
    )
    return tuple(Path(pts, w, p.kind) for (pts, w), p in zip(simple, paths, strict=True) if len(pts) >= 2)


def _link_key(
    paths: tuple[Path, ...], region, pitch: float, field=None, link_options=None, band=None,
    field_id: str | None = None,
) -> str:
    """Key of one :func:`link_paths` call in the cache: the paths' and the region's exact bytes, the pitch.

    Exact (no snapping): the links are a function of exactly these inputs, so a hit gives the very
    runs a new linking would; with a ``field`` (the cuts read it) its name ``field_id``
    (:func:`_field_id`: the analysis's key, its cut and the principal stress, which determine it),
    else its stress at every path vertex (sampling it was 0.26 s of a cached 100-layer run).  The
    options (``link_options``, None: the defaults of :class:`LinkOptions`) are named by their repr;
    the code by :func:`loadpath.cache.code_stamp`; the engine's ``band`` (:attr:`Toolpaths.band`) by
    its WKB.
    """
    return _link_keys(paths, region, pitch, field, link_options, band, field_id)[0]


def _link_keys(
    paths: tuple[Path, ...], region, pitch: float, field=None, link_options=None, band=None,
    field_id: str | None = None,
) -> tuple[str, str]:
    """:func:`_link_key` and the key for a near match, which names all but the region and the pitch
    (:func:`_near_links` compares them within ``TOL.region_reuse_mm`` and
    :data:`loadpath.pipeline.paths.NEAR_PITCH`): the paths (and the field) read once for both."""
    from loadpath.cache import code_stamp, digest
    from loadpath.engines.linking import LinkOptions

    lo = link_options if link_options is not None else LinkOptions()
    body: list[bytes | str] = []
    for p in paths:
        body += [p.kind, np.ascontiguousarray(p.points, dtype=float).tobytes()]
        body.append(np.ascontiguousarray(p.pitch, dtype=float).tobytes())
    if field is not None and paths:  # the cuts read the field (LinkOptions.cut_stress)
        if field_id is not None:
            body.append(f"field {field_id}")
        else:
            mag = field.sample(np.concatenate([p.points for p in paths])).magnitude
            body.append(np.ascontiguousarray(mag, dtype=float).tobytes())
    if band is not None:  # the paths' ends on it are linked along its edge
        body.append(shapely.to_wkb(band, hex=False))
    read = digest(body)
    where = shapely.to_wkb(region, hex=False) if region is not None else b"none"
    exact = digest(["links", code_stamp(), repr(lo), repr(float(pitch)), where, read])
    return exact, digest(["links near", code_stamp(), repr(lo), read])


_LINK_WORK: list[tuple[tuple[Path, ...], Any, float, Any, Any, Any]] = []
"""The linkings :func:`_link_all` hands to its worker processes (inherited by fork, not pickled)."""


def _link_one(i: int) -> tuple[tuple[Path, ...], dict]:
    ps, region, pitch, fld, lo, band = _LINK_WORK[i]
    return link_paths(ps, region, pitch, lo, field=fld, band=band)


def _link_all(
    tasks: list[tuple[tuple[Path, ...], Any, float, Any, Any, Any]], cache: Any, workers: int,
    kept: list[int], field_ids: Sequence[str | None] | None = None,
) -> list[tuple[tuple[Path, ...], dict]]:
    """Link every ``(paths, region, pitch, field, link options, band)`` of ``tasks``: ``(runs, stats)`` of
    :func:`link_paths` each.

    With a ``cache``: what it holds under :func:`_link_key` is loaded, the same key twice in the
    list is linked once, and what was linked is kept (``kept[0]`` counts the entries written).  The
    rest is linked in ``workers`` processes (forked: they inherit the tasks) when there are several,
    each layer on its own: the same runs as one process would link, in task order.
    """
    global _LINK_WORK
    out: list[tuple[tuple[Path, ...], dict] | None] = [None] * len(tasks)
    ids = field_ids if field_ids is not None else [None] * len(tasks)
    both = [_link_keys(*t, field_id=f) for t, f in zip(tasks, ids, strict=True)] if cache is not None else []
    keys = [b[0] for b in both] if cache is not None else [None] * len(tasks)
    first: dict[str, int] = {}
    todo = []
    for i, key in enumerate(keys):
        if key is not None:
            if key in first:
                continue
            first[key] = i
            hit = cache.get("links", key)
            if not (isinstance(hit, tuple) and len(hit) == 2) and tasks[i][1] is not None:
                hit = _near_links(cache, both[i][1], tasks[i][1], tasks[i][2])
                if hit is not None:
                    kept[0] += cache.put("links", key, hit, evict=False)  # found at once from now on
            if isinstance(hit, tuple) and len(hit) == 2:
                out[i] = hit
                continue
        todo.append(i)
    from loadpath.procs import fork_map

    _LINK_WORK = tasks
    try:
        for i, got in zip(todo, fork_map(_link_one, todo, workers), strict=True):
            out[i] = got
    finally:
        _LINK_WORK = []
    for i in todo:
        if keys[i] is not None:
            kept[0] += cache.put("links", keys[i], out[i], evict=False)
            if tasks[i][1] is not None:
                probe = (shapely.to_wkb(tasks[i][1]), float(tasks[i][2]))
                kept[0] += cache.keep_near("near-links", both[i][1], keys[i], probe)
    # a repeated key takes its first task's runs
    return [o if o is not None else out[first[k]] for o, k in zip(out, keys, strict=True)]  # type: ignore


def _near_links(  # type: ignore[no-untyped-def]
    cache: Any, near_key: str, region, pitch: float
) -> tuple | None:
    """The linked runs kept for the same paths in a region within ``TOL.region_reuse_mm`` of
    ``region`` (:func:`reuses`: as a layer prints its run's representative's runs), at a pitch within
    :data:`loadpath.pipeline.paths.NEAR_PITCH` (measured from the slicer's file), that lie in it
    (:func:`lies_in`), or None.  A re-slice by PrusaSlicer moves a region by micrometres; the engine's
    paths then come from the cache (:func:`loadpath.pipeline.paths.near_input`), and so do their links."""
    from loadpath.pipeline.paths import NEAR_PITCH

    for key, probe in cache.near("near-links", near_key):
        if not (isinstance(probe, tuple) and len(probe) == 2 and isinstance(probe[0], bytes)):
            continue
        wkb, was = probe
        if abs(float(pitch) - was) <= NEAR_PITCH * abs(was) and reuses(region, shapely.from_wkb(wkb)):
            hit = cache.get("links", key)
            if isinstance(hit, tuple) and len(hit) == 2 and lies_in(hit[0], region):
                return hit
    return None


def _fills(
    units: list[Unit],
    jobs: list[Job],
    results: list[tuple[Toolpaths, float]],
    options: PipelineOptions,
    plan: PlanOptions,
    shifted_paths: dict[int, Toolpaths] | None = None,
    cache=None,
    free_hop: float = 1.0,
    field_ids: Sequence[str | None] | None = None,
    *,
    engines: Sequence[str],
) -> tuple[list[EngineRun], list[BlockFill]]:
    """Paths of every job onto the blocks of every unit that uses them.

    ``shifted_paths`` (job index -> paths): the engine's own staggered copy of a job; other jobs'
    staggered copies (engines that cannot lay one) are their paths shifted by half a pitch
    (:func:`stagger`).  With a ``cache`` the linked runs are kept under :func:`_link_key` (a
    re-export links the same paths in the same region again).  What is linked is gathered first
    and linked by :func:`_link_all` (in ``options.workers`` processes when there are several).
    ``free_hop`` (mm): the longest travel the file's slicer makes without retracting (infinite
    where travels inside the region never retract, Cura's combing): the linking cuts paths to pair
    ends only where that saves retractions (:attr:`loadpath.engines.linking.LinkOptions.free_hop`).
    ``field_ids`` (per job, :func:`_field_id`): what names each job's field in the links' keys.
    ``engines`` (per job): the engine that laid it (its solid infill is linked with that engine's
    link options).
    """
    from loadpath.engines.linking import LinkOptions

    shifted_paths = shifted_paths or {}
    kept = [0]
    from loadpath.engines.registry import get as engine_named

    # the engine's own linking options (its paths' geometry: loadpath.engines.registry.Engine.linking),
    # for solid infill only: on sparse infill the level sets' wedge links cost the 3-point beam of
    # bench_sparse its failure load (PrusaSlicer gyroid 20 %: 1.882 -> 1.346x the slicer's; gyroid
    # 40 % 3.014 -> 2.154x), a link along each face beside the lines converging on it.  The engine's
    # band (Toolpaths.band) likewise: linked along it, sparse infill lost up to a fifth of its
    # failure load on bench_sparse's shelf (PrusaSlicer gyroid 40 %: 1.726 -> 1.365x the slicer's;
    # rectilinear 40 %: 1.901 -> 1.576x), the links' plastic taken from the lines at the slicer's mass,
    # and its retractions did not fall (the 3-point beam's rose: 3.32 -> 3.80x at gyroid 40 %)
    base_opts = LinkOptions(free_hop=free_hop) if math.isfinite(free_hop) else LinkOptions(cut_reach=0.0)
    solid_opts = {e: replace(base_opts, **dict(engine_named(e).linking)) for e in set(engines)}
    tasks: list[tuple[tuple[Path, ...], Any, float, Any, Any, Any]] = []
    task_fields: list[str | None] = []

    def task(
        ps: tuple[Path, ...], u: Unit, fld: Any = None, fid: str | None = None, ji: int = 0,
        shifted: bool = False, clipped: bool = False,
    ) -> int | None:
        """Index of the linking of job ``ji``'s ``ps`` in ``u``'s region (None: left as they are);
        ``shifted``: ``ps`` are (from) the job's staggered copy; ``clipped``: a layer's clipped
        variant, linked without the exact links (LinkOptions.exact: one per layer of a
        1000-layer specimen cost its run 4.7 s, 21.3 -> 26.1 s)."""
        if not options.link or len(ps) < 2:
            return None
        band = None  # sparse: no band (above), no runs inserted (LinkOptions.insert)
        if u.fixed_width:
            exact = SPARSE_EXACT if math.isfinite(free_hop) else 0
            lo = replace(
                base_opts.for_bead(u.flow_width, u.pitch), insert=False, exact=exact, exact_integers=0
            )
        else:
            lo = solid_opts[engines[ji]]
            # where the engine's paths end inside the region (Toolpaths.band): its own staggered
            # copy's, else the job's (a copy moved by stagger() keeps the job's band)
            own = shifted_paths.get(ji)
            band = own.band if shifted and own is not None and own.paths else results[ji][0].band
        if clipped:
            lo = replace(lo, exact=0)
        tasks.append((ps, u.fill_region, u.pitch, fld, lo, band))
        task_fields.append(fid)
        return len(tasks) - 1

    # first pass: every job's paths, their staggered copy and the clipped variants, and what to link
    planned = []
    for ji, (job, (tp, secs)) in enumerate(zip(jobs, results, strict=True)):
        members = sorted((units[i] for i in job.units), key=lambda m: m.layer)
        by_engine = ji in shifted_paths and bool(shifted_paths[ji].paths)
        base_raw = _simplified(tp.paths, plan, cache)
        fld = getattr(job.input, "field", None)
        fid = field_ids[ji] if field_ids is not None else None
        base_t = task(base_raw, job.unit, fld, fid, ji)
        shifted_raw, shifted_t = None, None
        rows = []
        for k, u in enumerate(members):
            use_shift = options.stagger and k % 2 == 1 and len(tp.paths) > 0
            if use_shift and shifted_raw is None:
                u0 = job.unit
                if by_engine:
                    shifted_raw = _simplified(shifted_paths[ji].paths, plan, cache)
                else:
                    moved = stagger(tp.paths, u0.fill_region, 0.25 * u0.pitch, u0.pitch)
                    shifted_raw = _simplified(moved, plan, cache)
                shifted_t = task(shifted_raw, u0, fld, fid, ji, True)
            clipped = clipped_t = None
            if not reuses(u.fill_region, job.unit.fill_region):
                # a region that differs by more than rounding (a sliver, TOL.region_reuse_mm): the
                # paths clipped to it, linked in it (links along the representative's edge would be
                # cut by the clipping)
                raw = shifted_raw if use_shift else base_raw
                clipped = clip_to(raw, u.fill_region, 2.0 * u.pitch)
                clipped_t = task(clipped, u, fld, fid, ji, use_shift, clipped=True)
            rows.append((u, use_shift, clipped, clipped_t))
        planned.append((job, tp, secs, members, by_engine, base_raw, base_t, shifted_raw, shifted_t, rows))

    linked = _link_all(tasks, cache, options.workers, kept, task_fields)

    # a layer prints the job's runs as they are only where they lie in its own region: reuses()
    # compares the regions, but the engine keeps only its vertices inside the representative's
    # region, and a segment between two of them can cut across a concave edge (a hole) that
    # clip_to trimmed when every other layer was clipped; those layers are cut and linked in their
    # own region after all (a second, short linking)
    first_late = len(tasks)
    for ji, (job, _, _, _, _, base_raw, base_t, shifted_raw, shifted_t, rows) in enumerate(planned):
        fld = getattr(job.input, "field", None)
        fid = field_ids[ji] if field_ids is not None else None
        for i, (u, use_shift, clipped, _) in enumerate(rows):
            if clipped is not None:
                continue
            raw, t = (shifted_raw, shifted_t) if use_shift else (base_raw, base_t)
            ps = raw if t is None else linked[t][0]
            if lies_in(ps, u.fill_region):
                continue
            clipped = clip_to(raw, u.fill_region, 2.0 * u.pitch)
            rows[i] = (u, use_shift, clipped, task(clipped, u, fld, fid, ji, use_shift, clipped=True))
    if len(tasks) > first_late:
        linked += _link_all(tasks[first_late:], cache, options.workers, kept, task_fields[first_late:])

    def runs_of(ps: tuple[Path, ...], t: int | None) -> tuple[Path, ...]:
        return ps if t is None else linked[t][0]

    # second pass: the runs onto the blocks
    per_block: dict[int, dict[str, Any]] = {}
    job_results = []
    for ji, (job, tp, secs, members, by_engine, base_raw, base_t, shifted_raw, shifted_t, rows) in enumerate(
        planned
    ):
        link_stats: dict = {}
        for t in (base_t, shifted_t):  # the representative's runs and their copy's are counted
            if t is not None:
                for k, v in linked[t][1].items():
                    if isinstance(v, (int, float)):
                        link_stats[k] = link_stats.get(k, 0) + v
        base = runs_of(base_raw, base_t)
        shifted = runs_of(shifted_raw, shifted_t) if shifted_raw is not None else None
        flags = []
        for u, use_shift, clipped, clipped_t in rows:
            paths = shifted if use_shift else base
            if clipped is not None:
                paths = runs_of(clipped, clipped_t)
            flags.append(use_shift)
            for block, ps in assign(paths, u).items():
                entry = per_block.setdefault(
                    block, {"paths": [], "regions": [], "unit": u, "scale": volume_scale(job)}
                )
                entry["paths"].extend(ps)
                entry["regions"].append(u.fill_region)
        job_results.append(
            EngineRun(
                job,
                members,
                tp,
                secs,
                flags,
                shifted or (),
                shifted is not None and by_engine,
                base if options.link else (),
                link_stats,
                engines[ji],
            )
        )
    if cache is not None and (kept[0] or cache.stats.misses.get("simplified")):
        cache.evict()
    fills = []
    for block, e in sorted(per_block.items()):
        u: Unit = e["unit"]
        region = e["regions"][0] if len(e["regions"]) == 1 else shapely.union_all(e["regions"])
        fills.append(
            BlockFill(
                block,
                tuple(e["paths"]),
                region,
                flow_width=u.flow_width if u.fixed_width else None,
                nominal_pitch=u.pitch,
                simplified=True,
                volume_scale=e["scale"],
                linked=options.link,
                comb=u.outline,
            )
        )
    return job_results, fills
