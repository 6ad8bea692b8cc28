"""Engine runs: one per distinct unit, in parallel processes, reused on identical layers.

(Over 400 lines: planning, running and reusing engine runs share the Job and its grouping rules;
split along those three when it grows further.)

Units share an engine run when they would get the same input: same object, kind, followed
principal stress, pitch, layer height and (for fixed-width kinds) flow width, a replace region that
is the same within ``TOL.region_compare_mm`` (:func:`loadpath.geometry.group_regions`), and the same
stress field: always for a 2D analysis (one field for the whole body), and for a 3D analysis only
when the two layers' principal directions agree (:func:`fields_agree`).

Every other layer that reuses paths gets them **staggered**, so the seams between beads do not
stack up layer on layer: an engine that takes a seed ``phase`` (:func:`lays_phase`: the swarm, the
streamlines' default mode) lays that copy itself in a second run from seeds half a pitch on; other
engines' paths are shifted sideways by half the local pitch and clipped to the region
(:func:`stagger`).

Sparse infill keeps the slicer's bead width, so its plastic is its length: a run whose paths
alone are longer than the slicer's extrusion by more than the splicer's flow correction can take
back (``max_correction``; in a narrow region one path more is a fifth of the layer) is run once
more at the pitch that scales its length onto the slicer's, and the closer of the two is kept
(:func:`_run_one`).  A run that is too short is not judged here: the printed links between path
ends add length the paths do not show (on Cura's 4 mm sparse pitch, links up to 8 mm long make up a
short run).  Once linked, a run still short by more than the flow correction is run again at a
closer pitch, and one its links made longer than the correction takes back at a wider one
(:func:`relay_factor`, ``pitch_factor`` of :func:`run_jobs`).

Engine runs go to worker processes (``fork``: the stress fields and regions are inherited, only the
paths come back) when there are several and ``jobs > 1``; results are collected by index, so the
output does not depend on the number of workers.

With a :class:`loadpath.cache.Cache`, each run's paths are kept under :func:`job_key` (what the
engine's output depends on) and a later run with the same key loads them: only the missing ones
are run (and only then is an engine, with its compiled kernels, loaded at all).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import shapely
from loadpath import engines
from loadpath._typing import Region
from loadpath.engines import Machine, generate
from loadpath.field import StressField
from loadpath.geometry import group_regions
from loadpath.pipeline.units import Unit
from loadpath.procs import fork_map, forks
from loadpath.tolerances import TOL
from loadpath.toolpath import EngineInput, Path, Toolpaths

__all__ = [
    "Job",
    "plan_jobs",
    "run_jobs",
    "relay_factor",
    "RELAYS",
    "lays_phase",
    "stagger",
    "assign",
    "share_volume",
    "clip_to",
    "fields_agree",
    "default_workers",
    "length_target",
    "job_key",
    "job_near_key",
    "near_input",
    "input_probe",
    "volume_scale",
    "reuses",
    "lies_in",
]


@dataclass
class Job:
    """One engine run.

    Attributes
    ----------
    unit : Unit
        The representative unit (the first in file order).
    principal : str
    input : EngineInput
    units : list of int
        Indices of the units that use these paths (the first is the representative).
    params : dict
        Engine parameters of this run on top of the shared ones (e.g. ``phase`` for the staggered
        copy of a run of identical layers, :func:`lays_phase`).
    """

    unit: Unit
    principal: str
    input: EngineInput = field(repr=False)
    units: list[int] = field(default_factory=list)
    params: dict[str, Any] = field(default_factory=dict)


def fields_agree(a: StressField, b: StressField, region: Region, cos_min: float = 0.99, n: int = 24) -> bool:
    """Whether two layers' fields send paths the same way over ``region``.

    On an ``n`` x ``n`` grid of points in the region: the valid masks agree on 95 % of the points and
    the mass-weighted mean ``|cos|`` between the principal directions is at least ``cos_min``.
    """
    x0, y0, x1, y1 = region.bounds
    gx, gy = np.meshgrid(np.linspace(x0, x1, n), np.linspace(y0, y1, n))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    pts = pts[shapely.contains_xy(region, pts[:, 0], pts[:, 1])]
    if len(pts) < 8:
        return True
    sa, sb = a.sample(pts), b.sample(pts)
    both = sa.valid & sb.valid
    if np.mean(sa.valid == sb.valid) < 0.95:
        return False
    if not both.any():
        return True
    cos = np.abs(np.sum(sa.direction[both] * sb.direction[both], axis=1))
    w = 0.5 * (sa.mass[both] + sb.mass[both]) + 1e-12
    return bool(np.sum(cos * w) / np.sum(w) >= cos_min)


def plan_jobs(
    units: Sequence[Unit],
    field_of: Callable[[Unit, str], StressField],
    principal_of: Callable[[Unit], str],
    analysis_kind: Callable[[Unit], str],
) -> list[Job]:
    """Group units into engine runs (see the module docstring).

    Parameters
    ----------
    units : sequence of Unit
    field_of : callable
        ``field_of(unit, principal) -> StressField`` of the unit's layer.
    principal_of : callable
        ``principal_of(unit) -> str``: the principal stress the unit's paths follow.
    analysis_kind : callable
        ``analysis_kind(unit) -> "2d" | "3d"``.
    """
    keyed: dict[tuple, list[int]] = {}
    band = _pitch_bands(units)
    for i, u in enumerate(units):
        key = (
            u.object,
            u.kind,
            principal_of(u),
            band[i],
            round(u.height, 3),
            round(u.flow_width, 3) if u.fixed_width else 0.0,
        )
        keyed.setdefault(key, []).append(i)
    jobs: list[Job] = []
    for key, idx in keyed.items():
        labels = group_regions([units[i].fill_region for i in idx])
        groups: dict[int, list[int]] = {}
        for i, lab in zip(idx, labels, strict=True):
            groups.setdefault(lab, []).append(i)
        for members in groups.values():
            pending = list(members)
            while pending:
                rep = units[pending[0]]
                f = field_of(rep, key[2])
                same = [pending[0]]
                rest = []
                for i in pending[1:]:
                    if analysis_kind(units[i]) == "2d" or fields_agree(
                        f, field_of(units[i], key[2]), rep.fill_region
                    ):
                        same.append(i)
                    else:
                        rest.append(i)
                entry = getattr(f, "load_entry", None)
                jobs.append(Job(rep, key[2], EngineInput(rep.fill_region, f, rep.pitch, entry), same))
                pending = rest
    jobs.sort(key=lambda j: min(j.units))
    return jobs


SPARSE_PITCH_BAND = 0.15
"""Sparse units whose plastic per area lies within this share of each other share an engine run
(the splicer's default ``max_correction``: its flow matching takes the difference back per block)."""


def _plastic_pitch(u: Unit) -> float:
    """Region area over the slicer's extruded length, mm: the pitch of the unit's plastic per area."""
    length = float(sum(b.length for b in u.blocks))
    return float(u.fill_region.area / length) if length > 0 else float(u.pitch)


def _pitch_bands(units: Sequence[Unit]) -> list[Any]:
    """A grouping key for each unit's pitch.

    Solid kinds: the pitch to a micrometre.  Fixed-width (sparse) kinds: a band of plastic per area
    (:func:`_plastic_pitch`) within :data:`SPARSE_PITCH_BAND` of the band's smallest.  A sparse
    layer's plastic differs from layer to layer where the pattern does (PrusaSlicer 2.5 on the
    specimen at 20 %: gyroid 1.82-2.11 mm of area per mm of line, cubic 1.94-1.97 mm; 3D honeycomb
    2600-3050 mm of lines per layer, measured pitch 1.07-1.92 mm), so a key to the micrometre made every such
    layer an engine run of its own; the splicer's flow matching takes the difference back per block
    (its ``max_correction`` is 0.15).
    """
    out: list[Any] = [round(u.pitch, 3) for u in units]
    sparse = sorted((_plastic_pitch(u), i) for i, u in enumerate(units) if u.fixed_width)
    start, band = None, -1
    for p, i in sparse:
        if start is None or p > start * (1.0 + SPARSE_PITCH_BAND):
            start, band = p, band + 1
        out[i] = ("band", band)
    return out


# ---------------------------------------------------------------------------------------------- running

_WORK: list[tuple[str, EngineInput, dict[str, Any], float | None, float, Machine | None]] = []

_PITCH_STEP = (0.6, 1.6)  # bounds of the second run's pitch, as a factor of the first's

SHORT_AIM = 0.5
"""A linked run short of the slicer's length by more than the flow correction is run again aiming
this share of the correction under that length (0.5: 7.5 % under at the default 0.15): its links,
laid again, add length once more.  The streamline engine on CuraEngine's 40 % L-bracket
(``benchmarks/bench_printability.py``) laid 72-74 % of the slicer's length and 79 % linked; the flow
correction's 15 % left every block at 91 %, all kept as sliced.  Judged on the engine's length alone
the same rule hit runs the links make up (the 40 % beam's streamlines, 73 % alone).  A linked run
too long by more than the correction is run again aiming the same share over the slicer's length:
at the bead's share of the clearance (:meth:`loadpath.engines.linking.LinkOptions.for_bead`) the
swarm's sparse links on CuraEngine's 40 % beam came to 120 % of it and every block was kept as
sliced."""


def job_key(
    job: Job, engine: str, params: Mapping[str, Any], field_id: str, length_retry: float, pitch_factor: float = 1.0
) -> str:
    """Key of one engine run's paths in the cache (:mod:`loadpath.cache`).

    Parameters
    ----------
    job : Job
    engine : str
    params : mapping
        The shared engine parameters (the job's own, e.g. ``phase``, are added here).
    field_id : str
        Names the stress field followed: the analysis's :func:`loadpath.cache.fea_key`, the layer
        height it is cut at (or ``2d``) and the principal stress.
    length_retry : float
        As :func:`run_jobs` (a fixed-width job may be run again at another pitch).
    pitch_factor : float
        As :func:`run_jobs`: the engine ran at the job's pitch times this.

    The rest comes from the job: its region (to 1 µm), pitch (to 1 µm), load entry, seed, its
    density field (:func:`density_bytes`) and, for a fixed-width job, the slicer's extruded length
    it matches and its flow width (the machine fact the engines receive, :func:`_machine_of`; to 1 µm).
    """
    from loadpath.cache import digest, geometry_bytes

    inp, target = job.input, length_target(job)
    return digest(
        [
            *_job_parts(job, engine, params, field_id, length_retry, pitch_factor),
            "none" if target is None else f"{target:.3f}",
            geometry_bytes(inp.region),
            geometry_bytes(inp.load_entry),
            density_bytes(inp.density),
        ]
    )


def _job_parts(
    job: Job, engine: str, params: Mapping[str, Any], field_id: str, length_retry: float, pitch_factor: float,
    near: bool = False,
) -> list[str]:
    """What :func:`job_key` and :func:`job_near_key` both name: the code, engine and parameters, the
    field, the seed and retry, and (``near`` False) the pitch and the flow width, which a near match
    compares within tolerances (:func:`near_input`: the slicer's line spacing is measured from its file)."""
    from loadpath.cache import code_stamp

    inp = job.input
    merged = {**params, **job.params}
    width = f"{job.unit.flow_width:.6f}" if job.unit.fixed_width else "solid"
    if near:
        width = "fixed" if job.unit.fixed_width else "solid"
    return [
        "paths",
        code_stamp(),
        engine,
        repr(sorted((str(k), repr(v)) for k, v in merged.items())),
        field_id,
        (f"{inp.seed} {length_retry!r}" if near else f"{inp.pitch:.6f} {inp.seed} {length_retry!r}")
        + ("" if pitch_factor == 1.0 else f" x{pitch_factor!r}"),
        width,
    ]


def job_near_key(
    job: Job, engine: str, params: Mapping[str, Any], field_id: str, length_retry: float,
    pitch_factor: float = 1.0,
) -> str:
    """Key of an engine run's paths for a near match: :func:`job_key`'s without the region, the load
    entry, the length matched, the density field, the pitch and the flow width, which
    :func:`near_input` compares within tolerances (:meth:`loadpath.cache.Cache.near`)."""
    from loadpath.cache import digest

    return digest(["near", *_job_parts(job, engine, params, field_id, length_retry, pitch_factor, near=True)])


NEAR_LENGTH = 1e-3
"""Largest relative change of the slicer's extruded length a fixed-width job matches, and of its
density field's pitch in any cell, with which an engine run's kept paths serve it."""

NEAR_PITCH = 0.01
"""Largest relative change of a job's pitch and flow width (both measured from the slicer's file)
with which an engine run's kept paths serve it: the gusset's solid pitch read 0.43 % apart on two
slices of one STL; the splicer matches each block's plastic to the slicer's (up to 15 %)."""


def input_probe(job: Job) -> tuple:
    """What :func:`near_input` compares: the job's region and load entry (WKB), the length it
    matches, its density field's pitch per cell (None without one), its pitch and flow width."""
    inp = job.input
    wkb = [None if g is None else shapely.to_wkb(g) for g in (inp.region, inp.load_entry)]
    df = inp.density
    dens = None
    if df is not None:
        dens = (tuple(np.round(df.origin, 6)), round(float(df.cell), 6), np.asarray(df.pitch, float))
    return wkb[0], wkb[1], length_target(job), dens, float(inp.pitch), float(job.unit.flow_width)


def near_input(kept: tuple, job: Job, tol: float = TOL.region_reuse_mm) -> bool:
    """Whether an engine run kept for the input ``kept`` (:func:`input_probe`) serves ``job``.

    Its region and load entry within ``tol`` of the job's (:func:`reuses`: the tolerance within which
    a layer prints its run's representative's paths as they are), the length it matched within
    :data:`NEAR_LENGTH`, its density field on the same grid (moved by at most ``tol``) with every
    pitch within as much, its pitch and flow width within :data:`NEAR_PITCH`.  A re-slice
    by PrusaSlicer 2.5 on all its threads moved a 40-layer gusset's solid-infill regions by up to
    13.5 um, and 6 of its 13 engine runs were laid again.
    """
    if not (isinstance(kept, tuple) and len(kept) == 6):
        return False
    region, entry, target, dens, pitch0, width0 = kept
    inp = job.input
    for was, now in ((pitch0, float(inp.pitch)), (width0, float(job.unit.flow_width))):
        if abs(now - was) > NEAR_PITCH * abs(was):
            return False
    for wkb, geom in ((region, inp.region), (entry, inp.load_entry)):
        if (wkb is None) != (geom is None):
            return False
        if wkb is not None and not reuses(geom, shapely.from_wkb(wkb), tol):
            return False
    now = length_target(job)
    if (target is None) != (now is None):
        return False
    if now is not None and abs(now - target) > NEAR_LENGTH * abs(target):
        return False
    df = inp.density
    if (dens is None) != (df is None):
        return False
    if df is None:
        return True
    origin, cell, pitch = dens
    new = np.asarray(df.pitch, float)
    moved = float(np.max(np.abs(np.asarray(origin) - np.asarray(df.origin, float))))
    if moved > tol or abs(float(df.cell) - cell) > NEAR_LENGTH * cell or pitch.shape != new.shape:
        return False  # the grid follows the region's bounds: moved with it, by micrometres
    both = np.isfinite(pitch) & np.isfinite(new)
    return bool(np.array_equal(np.isfinite(pitch), np.isfinite(new))
                and np.all(np.abs(new[both] - pitch[both]) <= NEAR_LENGTH * np.abs(pitch[both])))


def density_bytes(df: Any) -> bytes:
    """Canonical bytes of a job's density field (:class:`loadpath.density.DensityField`; None: ``none``).

    Its grid (origin and cell to 1 µm), flow width and pitch per cell (to 1 µm): what the zones the
    engine lays are cut from.  Without it a run with ``density = "uniform"`` and one with a density
    field on the same region shared one cache entry (bench_sparse: identical files).
    """
    if df is None:
        return b"none"
    pitch = np.nan_to_num(np.round(np.asarray(df.pitch, dtype=float), 3), nan=-1.0)
    head = f"{df.origin[0]:.3f} {df.origin[1]:.3f} {df.cell:.3f} {df.flow_width:.3f} {pitch.shape}"
    return head.encode() + b"\0" + pitch.tobytes()


def volume_scale(job: Job) -> float:
    """The job's plastic over the slicer's: 1, or the user's sparse fill over the slicer's.

    A job with a density field set to the user's fill (:func:`loadpath.pipeline.with_density`) has
    its nominal pitch at that fill, the unit keeps the slicer's.
    """
    if job.input.density is None or not job.unit.fixed_width:
        return 1.0
    return float(job.unit.pitch / job.input.pitch)


def length_target(job: Job) -> float | None:
    """Return the extruded length a fixed-width job's paths should match, mm (else None).

    The slicer's, times :func:`volume_scale`.
    """
    u = job.unit
    if not u.fixed_width:
        return None
    total = float(sum(b.length for b in u.blocks)) * volume_scale(job)
    return total if total > 0 else None


def _machine_of(machine: Machine | None, job: Job) -> Machine | None:
    """The machine facts of one job: the run's, with the slicer's flow width where the job keeps it
    (sparse infill printed at the slicer's bead width; the engines that declare ``flow_width``)."""
    if machine is None or not job.unit.fixed_width:
        return machine
    return replace(machine, flow_width=float(job.unit.flow_width))


def _run_one(i: int) -> tuple[Toolpaths, float]:
    engine, inp, params, target, retry, machine = _WORK[i]
    t0 = time.perf_counter()
    tp = generate(engine, inp, machine, **params)
    if target:
        got = tp.total_length
        if got > target * (1.0 + retry):
            pitch = inp.pitch * float(np.clip(got / target, *_PITCH_STEP))
            again = generate(engine, replace(inp, pitch=pitch), machine, **params)
            got2 = again.total_length
            if abs(got2 / target - 1.0) < abs(got / target - 1.0):
                again.stats["pitch_matched_to_length"] = pitch
                tp = again
    return tp, time.perf_counter() - t0


RELAYS = 3
"""Most times one linked fixed-width layer is laid again at another pitch (:func:`relay_factor`)."""


def relay_factor(tried: Sequence[tuple[float, float]], target: float, retry: float) -> float | None:
    """The pitch factor to lay one linked fixed-width layer again at, or None (no need, or none left).

    Parameters
    ----------
    tried : sequence of (float, float)
        The factors on the job's pitch laid so far and the layer's linked length at each, mm, in
        the order laid.
    target : float, mm
        The slicer's length (:func:`length_target`).
    retry : float
        The share the splicer's flow correction takes back (``max_correction``).

    Returns
    -------
    float or None
        None where the last length lies within ``retry`` of the target, or where the next factor
        was tried already.  Otherwise, where one factor laid it short and another long, their
        geometric mean; else the last factor scaled so that the length lands :data:`SHORT_AIM` of
        ``retry`` under (short) or over (long) the target, within ``_PITCH_STEP``.

    Notes
    -----
    Why more than one relay, each layer on its own: in a small region one level set more or
    less is a fifth of the layer, and a layer and its staggered copy link differently.  A 20 x 20
    mm part with an 8 mm hole at CuraEngine's 20 % grid: a layer linked 123 % of the slicer's
    length and its copy 77 %; one factor for both, taken from the shorter, laid them 73 % and
    136 % long, and every sparse layer of the part was kept as sliced.
    """
    f, length = tried[-1]
    lo, hi = target * (1.0 - retry), target * (1.0 + retry)
    if lo <= length <= hi or length <= 0.0:
        return None
    short = [a for a, got in tried if got < lo]  # these want a closer pitch (a smaller factor)
    long = [a for a, got in tried if got > hi]  # and these a wider one
    if short and long:
        a, b = max(long), min(short)
        if not a < b:
            return None
        new = float(np.sqrt(a * b))
    else:
        aim = target * (1.0 - SHORT_AIM * retry) if length < lo else target * (1.0 + SHORT_AIM * retry)
        new = float(np.clip(f * length / aim, *_PITCH_STEP))
    if any(abs(new / a - 1.0) < 1e-3 for a, _ in tried):
        return None
    return new


def default_workers() -> int:
    """Worker processes by default: the usable cores, at most 4."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover (not Linux)
        n = os.cpu_count() or 1
    return max(1, min(4, n))


def run_jobs(
    jobs: Sequence[Job],
    engine: str | Sequence[str],
    params: Mapping[str, Any] | Sequence[Mapping[str, Any]],
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
    length_retry: float = 0.15,
    machine: Machine | None = None,
    cache: Any = None,
    keys: Sequence[str] | None = None,
    pitch_factor: Sequence[float] | None = None,
    near_keys: Sequence[str] | None = None,
) -> list[tuple[Toolpaths, float]]:
    """Run every job's engine; ``(paths, seconds)`` per job, in job order.

    Parameters
    ----------
    jobs : sequence of Job
    engine : str or sequence of str
        The engine of every job, or one per job (sparse infill may have its own).
    params : mapping or sequence of mapping
        Engine parameters (``K``, ...): for every job, or one mapping per job.
    workers : int
        Processes; 1 runs in this process.
    progress : callable, optional
        ``progress(done, total)`` after each job.
    length_retry : float
        A fixed-width job whose paths are longer than :func:`length_target` by more than this share
        is run again at the matching pitch: the splicer's ``max_correction`` (its flow correction
        takes back that much at most, the printed links only add length).
    machine : Machine, optional
        The machine facts; each engine receives those it declares (:mod:`loadpath.engines.registry`).
    cache : loadpath.cache.Cache, optional
        Where the paths of earlier runs are kept; with ``keys`` (one :func:`job_key` per job) the
        jobs found there are not run (their seconds are 0), the others are run and kept.
    keys : sequence of str, optional
    near_keys : sequence of str, optional
        One :func:`job_near_key` per job: a job its exact key misses takes the paths kept for an
        input :func:`near_input` accepts, when they lie in its region (:func:`lies_in`); each run
        job is kept under its near key too.
    pitch_factor : sequence of float, optional
        Per job, the engine runs at the job's pitch times this (:func:`short_runs`); the job itself,
        and so the length its paths match (:func:`length_target`), stays as it is.
    """
    global _WORK
    factors = list(pitch_factor) if pitch_factor is not None else [1.0] * len(jobs)
    names = [engine] * len(jobs) if isinstance(engine, str) else list(engine)
    each = [params] * len(jobs) if isinstance(params, Mapping) else list(params)
    _WORK = [
        (
            name,
            j.input if f == 1.0 else replace(j.input, pitch=j.input.pitch * f),
            {**p, **j.params},
            length_target(j),
            length_retry,
            _machine_of(machine, j),
        )
        for j, f, name, p in zip(jobs, factors, names, each, strict=True)
    ]
    n = len(jobs)
    out: list[tuple[Toolpaths, float] | None] = [None] * n
    if cache is not None and keys is not None:
        for i, k in enumerate(keys):
            hit = cache.get("paths", k)
            if not isinstance(hit, Toolpaths) and near_keys is not None:
                hit = _near_paths(cache, near_keys[i], jobs[i])
                if hit is not None:
                    cache.put("paths", k, hit, evict=False)  # found at once from now on
            if isinstance(hit, Toolpaths):
                out[i] = (hit, 0.0)
    todo = [i for i in range(n) if out[i] is None]
    if progress and len(todo) < n:
        progress(n - len(todo), n)
    try:
        if forks(workers, len(todo)):
            # compile (or load) an engine's compiled kernels once here: forked workers inherit
            # them, where each would otherwise compile them on its own on a cold cache
            for name in dict.fromkeys(names[i] for i in todo):
                engines.warm_up(name)
        done = [n - len(todo)]

        def arrived(k: int, got: tuple[Toolpaths, float]) -> None:
            out[todo[k]] = got
            done[0] += 1
            if progress:
                progress(done[0], n)

        fork_map(_run_one, todo, workers, arrived)
    finally:
        _WORK = []
    if cache is not None and keys is not None:
        for i in todo:
            o = out[i]
            if o is not None:
                cache.put("paths", keys[i], o[0], evict=False)
                if near_keys is not None:
                    cache.keep_near("near-paths", near_keys[i], keys[i], input_probe(jobs[i]))
        if todo:
            cache.evict()
    return [o for o in out if o is not None]


def _near_paths(cache: Any, near_key: str, job: Job) -> Toolpaths | None:
    """The paths kept for an input near ``job``'s (:func:`near_input`) that lie in its region, or None."""
    for key, probe in cache.near("near-paths", near_key):
        if near_input(probe, job):
            hit = cache.get("paths", key)
            if isinstance(hit, Toolpaths) and lies_in(hit.paths, job.input.region):
                return hit
    return None


# ---------------------------------------------------------------------------------------------- reuse


def lays_phase(engine: str, params: Mapping[str, Any]) -> bool:
    """Whether the engine, run with these parameters, lays a staggered copy itself (option ``phase``).

    The registry says (:meth:`loadpath.engines.Engine.lays_phase`): the swarm and the streamline
    engine's default mode take ``phase = 0.5``: their seeds, one pitch apart, move on by half a
    pitch, so the copy is a whole layer whose paths run between the first one's.  Faithful
    streamlines (lattice or element-centroid seeds) have no such seeds; their copy is the paths
    shifted sideways (:func:`stagger`).
    """
    return engines.get(engine).lays_phase(params)


def _dominant_normal(paths: Sequence[Path]) -> np.ndarray:
    """Return the unit normal of the paths' dominant direction (length-weighted doubled-angle mean)."""
    d = np.concatenate([np.diff(p.points, axis=0) for p in paths]) if paths else np.zeros((0, 2))
    length = np.hypot(d[:, 0], d[:, 1])
    ang = np.arctan2(d[:, 1], d[:, 0])
    c, s = np.sum(length * np.cos(2 * ang)), np.sum(length * np.sin(2 * ang))
    theta = 0.5 * np.arctan2(s, c)
    return np.array([-np.sin(theta), np.cos(theta)])


def stagger(
    paths: Sequence[Path], region: Region, inset: float, pitch: float | None = None
) -> tuple[Path, ...]:
    """Paths shifted sideways by half their local pitch, clipped to ``region`` shrunk by ``inset``.

    Every path moves to the same side (the side of the paths' dominant normal), each vertex along the
    path's local normal by half its pitch, so a shifted path runs between two original ones.  Pieces
    shorter than two pitches are dropped.

    With ``pitch`` (the nominal pitch) the shifted layer is then made whole again, as the engines
    make theirs: the bead widths are measured on the shifted paths (the outermost path on the side
    the paths moved away from widens to reach the edge; :func:`loadpath.engines.finish.widths.local_pitch`)
    and the path ends clipped short are carried on to the next bead or the edge
    (:func:`loadpath.engines.finish.ends.extend_ends`).  Without that a staggered layer lost a half
    pitch strip along every wall parallel to the paths and a void at every clipped end (bench
    L-bracket: coverage 93.7 % against 95.6 % unstaggered).
    """
    ref = _dominant_normal(paths)
    inner = region.buffer(-inset) if inset > 0 else region
    shapely.prepare(inner)
    out = []
    for p in paths:
        pts = p.points
        t = np.gradient(pts, axis=0)
        t /= np.maximum(np.hypot(t[:, 0], t[:, 1]), 1e-12)[:, None]
        nrm = np.column_stack([-t[:, 1], t[:, 0]])
        side = 1.0 if float(np.mean(nrm @ ref)) >= 0 else -1.0
        q = pts + side * nrm * (p.pitch[:, None] / 2)
        inside = shapely.contains_xy(inner, q[:, 0], q[:, 1])
        cuts = np.flatnonzero(np.diff(inside.astype(np.int8))) + 1
        for a, z in zip(np.r_[0, cuts], np.r_[cuts, len(q)], strict=True):
            if not inside[a] or z - a < 2:
                continue
            piece = q[a:z]
            if np.sum(np.hypot(*np.diff(piece, axis=0).T)) >= 2 * float(np.median(p.pitch)):
                out.append(Path(piece, p.pitch[a:z], p.kind))
    if pitch is None or not out:
        return tuple(out)
    from loadpath.engines.finish.ends import extend_ends
    from loadpath.engines.finish.widths import local_pitch

    width = local_pitch([p.points for p in out], region, pitch)
    pts, width, _ = extend_ends([p.points for p in out], width, region, pitch, edge_gap=inset / pitch)
    return tuple(Path(q, w, p.kind) for q, w, p in zip(pts, width, out, strict=True))


def reuses(region: Region, representative: Region, tol: float = TOL.region_reuse_mm) -> bool:
    """Whether a unit with ``region`` prints its job representative's linked runs as they are.

    True when the two boundaries lie within ``tol`` (mm) of each other, both ways (the discrete
    Hausdorff distance of the two regions' vertices to the other's boundary): the runs then leave the
    unit's region by at most ``tol``, and its links along the edge follow its own perimeters within
    that.  Otherwise the paths are cut to the region (:func:`clip_to`) and linked in it: a region that
    lacks a sliver, or has one more, is that far off at the sliver's vertices.
    """
    if region.equals(representative):
        return True
    return bool(shapely.hausdorff_distance(region, representative) <= tol)


def lies_in(paths: Sequence[Path], region: Region, tol: float = TOL.region_reuse_mm) -> bool:
    """Whether every segment of ``paths`` lies within ``tol`` (mm) of ``region``.

    The test a layer's reused runs must pass (:func:`reuses` compares the regions alone): an engine
    keeps its polylines' vertices in the region it was given, not their segments, and a segment
    between two vertices on either side of a concave edge cuts across it (the streamlines' sparse
    steps are 3.5 mm long at a 4 mm pitch: one ran 0.35 mm into a 3.8 mm hole between vertices 0.17
    and 0.01 mm inside).  Exact for the segments, not just the vertices: the paths must be covered by
    the region grown by ``tol``.
    """
    ps = [p.points for p in paths if len(p.points) >= 2]
    if not ps:
        return True
    index = np.repeat(np.arange(len(ps)), [len(q) for q in ps])
    lines = shapely.linestrings(np.concatenate(ps), indices=index)
    grown = region.buffer(tol, quad_segs=4) if tol > 0 else region  # its arcs' chords lie inside the true one
    # a line that meets no edge of the grown region lies wholly inside it or wholly outside, as its
    # first vertex does; only the lines that meet an edge are tested whole (the 1000-layer specimen's
    # 980 reused layers: 0.85 -> 0.2 s, covered_by on every line testing each of its 7000 vertices)
    edge = shapely.boundary(grown)
    shapely.prepare(edge)
    meets = shapely.intersects(edge, lines)
    first = np.array([q[0] for q, m in zip(ps, meets, strict=True) if not m]).reshape(-1, 2)
    if not shapely.contains_xy(grown, first[:, 0], first[:, 1]).all():
        return False
    return bool(shapely.covered_by(lines[meets], grown).all())


def clip_to(paths: Sequence[Path], region: Region, min_length: float) -> tuple[Path, ...]:
    """Paths cut to ``region``: what lies outside is dropped, pieces shorter than ``min_length`` too.

    A job's paths are laid in its representative unit's region; another unit of the job may differ
    from it by a little (the grouping tolerance) or, where a layer's perimeters differ locally, by
    a sliver (a 1000-layer specimen had one layer whose region lacked 0.75 mm² next to the hole,
    and a reused path ran 1.4 mm into its perimeters).  Paths wholly inside are kept as they are;
    the others are intersected with the region, each new vertex taking the width of the nearest
    old one.
    """
    if not paths:
        return ()
    lines = np.array([shapely.LineString(p.points) for p in paths], dtype=object)
    grown = region.buffer(1e-6)
    shapely.prepare(grown)
    inside = shapely.within(lines, grown)
    if inside.all():
        return tuple(paths)
    out: list[Path] = []
    for p, line, ok in zip(paths, lines, inside, strict=True):
        if ok:
            out.append(p)
            continue
        for g in shapely.get_parts(shapely.intersection(line, region)):
            if g.geom_type != "LineString" or g.length < min_length:
                continue
            q = shapely.get_coordinates(g)
            near = np.argmin(np.sum((q[:, None, :] - p.points[None, :, :]) ** 2, axis=2), axis=1)
            out.append(Path(q, p.pitch[near], p.kind))
    return tuple(out)


def assign(paths: Sequence[Path], unit: Unit) -> dict[int, list[Path]]:
    """Share a unit's paths among its blocks: each path goes to the block whose region holds its middle.

    A block left without a path while another holds several takes the path whose middle lies
    nearest its region: kept as sliced for want of one ("no new path fits"), it printed the
    slicer's lines where its siblings' runs already lay (a tapered cantilever at PrusaSlicer 100 %,
    its solid infill under the slope beside the internal infill).
    """
    ids = [b.block_index for b in unit.blocks]
    if len(ids) == 1:
        return {ids[0]: list(paths)}
    mids = np.array([p.points[len(p.points) // 2] for p in paths]).reshape(-1, 2)
    d = np.stack([shapely.distance(b.region, shapely.points(mids)) for b in unit.blocks], axis=1)
    best = np.argmin(d, axis=1) if len(mids) else np.zeros(0, dtype=int)
    for k in range(len(ids)):
        held = np.bincount(best, minlength=len(ids))
        if held[k] == 0 and held.max() > 1:
            movable = held[best] > 1
            best[np.flatnonzero(movable)[np.argmin(d[movable, k])]] = k
    out: dict[int, list[Path]] = {i: [] for i in ids}
    for p, k in zip(paths, best, strict=True):
        out[ids[int(k)]].append(p)
    return out


EMPTIED_COVER = 0.5
"""A block left without a run is emptied when at least this share of its region lies within a pitch
of the unit's runs (else the unit keeps its blocks' own plastic, and the splice keeps what falls short)."""


def _runs_cover(u: Unit, fills: Sequence[Any], laid: np.ndarray) -> bool:
    """Whether the unit's runs cover (:data:`EMPTIED_COVER`) the region of each of its run-less blocks."""
    lines = [shapely.LineString(p.points) for f in fills for p in f.paths if len(p.points) >= 2]
    if not lines:
        return False
    reach = shapely.union_all(lines).buffer(u.pitch)
    for b, v in zip(u.blocks, laid, strict=True):
        if v <= 0:
            region = b.region
            if region.is_empty or shapely.intersection(region, reach).area < EMPTIED_COVER * region.area:
                return False
    return True


def share_volume(fills: Sequence[Any], units: Sequence[Unit], filament: Callable[[int], float]) -> list[Any]:
    """The plastic of a unit of several blocks shared among them as its runs are (``BlockFill`` in and out).

    :func:`assign` gives each run to the block whose region holds its middle, but a linked run
    crosses from one block's region into the next: the slicer's internal infill and the solid
    infill under a sloped top, both solid at 100 %, are one unit, and on a tapered cantilever
    (90 mm long, 8 -> 2 mm tall, PrusaSlicer 100 %) the runs gave the solid infill 0.04-0.53 of the
    unit's deposit where the slicer gave it 0.05-0.40, up to 1.38x its own plastic: 23 blocks were
    kept as sliced ("the new paths would extrude 119 % ..."), with their siblings' runs beside them.
    Here each block of such a unit aims at the unit's plastic times its runs' share of the unit's
    deposit (its runs' length at a fixed flow width, else their ``area``): every run of the unit
    prints at one flow, and the unit lays the slicer's plastic (times its ``volume_scale``).

    A block that got no run (a unit linked into fewer runs than it has blocks) aims at none where
    the unit's runs cover most of its region (:data:`EMPTIED_COVER`): the splicer empties it
    (:func:`loadpath.splice.rewrite.rewrite_block`) and its plastic goes to the blocks whose runs
    print there, under their own feature name (the check lets a layer lose an emptied block's
    feature type).  Before 2026-12-07 such a unit kept its blocks' own plastic: the block holding
    the runs then extruded 106-523 % of its own and the whole unit was kept as sliced, "no new path
    fits in its 324.6 mm of bead" (a 24-tooth gear at PrusaSlicer 20 % gyroid), or, where that
    block's plastic held, its runs printed over the pathless block's own lines kept beside them (a
    PrusaSlicer 0.6 mm solid bit beside 100 % internal infill; an eye of a hook at 15 %: 232 mm
    of bead where its neighbours have 148).

    Parameters
    ----------
    fills : sequence of BlockFill
    units : sequence of Unit
    filament : callable
        ``filament(block) -> mm``: the slicer's filament of a block (``Program.block(b).e``).

    Returns
    -------
    list of BlockFill
        ``fills`` with the shared blocks' ``volume_scale`` set and ``shared`` true.  A unit keeps its
        blocks' own plastic where a block reaches into another island (its ``share`` below 1), or got
        no run and the runs miss most of its region.
    """
    at = {f.block: k for k, f in enumerate(fills)}
    seen: dict[int, int] = {}
    for u in units:
        for b in u.blocks:
            seen[b.block_index] = seen.get(b.block_index, 0) + 1
    out = list(fills)
    for u in units:
        ids = [b.block_index for b in u.blocks]
        if len(ids) < 2 or any(
            b.share < 1.0 - 1e-9 or seen[b.block_index] > 1 or b.block_index not in at for b in u.blocks
        ):
            continue
        laid = np.array([sum(p.length if u.fixed_width else p.area for p in fills[at[i]].paths) for i in ids])
        own = np.array([filament(i) for i in ids])
        if not (laid > 0).any() or not (own > 0).all():
            continue
        if not (laid > 0).all() and not _runs_cover(u, [fills[at[i]] for i in ids], laid):
            continue
        aim = own.sum() * laid / laid.sum()
        for i, a, e in zip(ids, aim, own, strict=True):
            f = fills[at[i]]
            out[at[i]] = replace(f, volume_scale=f.volume_scale * float(a / e), shared=True)
    return out
