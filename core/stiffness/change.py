"""What a run changed in the part's predicted response: the one function a run's verdict calls.

:func:`predicted_change` compares the slicer's file with the run's output under the run's load case
with the model of ``loadpath compare`` (:mod:`loadpath.stiffness.model`: the same options, material
card, mesh and first-ply failure as :func:`loadpath.stiffness.compare.evaluate_file`), on the beads of
the two files as printed, so the verdict's figures are ``compare``'s.  It costs two solves per body
(one when the slicer's prediction is in the cache).  :func:`change_from_results` makes the same
figures from two :class:`~loadpath.stiffness.compare.FileResult` already computed (``density =
"auto"`` evaluates every candidate against the slicer's file), with no further solve.

Measured before this model was shared (the verdict on the run's own FEA mesh, beads every 0.5 mm,
the engine's paths as beads, against ``compare``, stiffness / failure load): L-bracket PrusaSlicer
gyroid 20 % ``replace = sparse`` +6.1 / -13.6 % against +19.7 / +8.3 %; 3-point beam +5.4 / +156 %
against +26.3 / +66 %; the shipped example (solid) +0.1 / +12.3 % against +1.2 / +5.0 %.

With a :class:`loadpath.cache.Cache` and the bodies' FEA keys, each of the two predictions (the
slicer's beads, the output's) is kept under :func:`prediction_key`: the deposits' own bytes, the
analysis (its key names the body's outlines, load case and supports, which the mesh derives from),
the options, the card and the code.  A run with other loadpath settings re-uses the slicer's.  A
re-export with other speeds or temperatures deposits nearly the same beads, not the same: PrusaSlicer
2.5 moved 4 of the shipped example's 7657 beads by up to 0.06 mm and changed 8 volumes by up to
0.005 mm³ (``benchmarks/bench_latency.py``'s re-slice), which missed both predictions and made the
verdict 2.4 of the re-export's 2.9 s.  So each prediction is also kept under :func:`near_key`
(everything but the beads' count, order, positions and volumes) with its beads, and a run whose beads
lay the same material in the same places uses it (:mod:`loadpath.stiffness.near`: within a tenth of
a millimetre and 5 % at every node of a 1 mm grid, in any order; ``cache.stats`` counts a ``near``
hit): its figures are those of beads within a tenth of a millimetre, far below what the model
resolves (its strength is averaged over two bead widths, its mesh is a millimetre).  Matched bead
for bead (until 2026-12-06), a re-slice of a 40-layer gyroid gusset missed: PrusaSlicer wrote a
third of its layers' perimeters and sparse lines in another order (:mod:`loadpath.stiffness.near`).
"""

from __future__ import annotations

import time
from contextlib import nullcontext
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np
from loadpath.errors import LoadpathError
from loadpath.stiffness.beads import layer_store
from loadpath.stiffness.cards import MaterialCard
from loadpath.stiffness.deposits import Deposits, Stack, from_program
from loadpath.stiffness.model import body_mesh, file_card, mesh_key, sample_count, solve_body
from loadpath.stiffness.near import Beads, agrees, group_bytes, match, summary
from loadpath.stiffness.predict import StiffnessOptions

__all__ = [
    "StiffnessChange",
    "BodyChange",
    "predicted_change",
    "change_from_results",
    "prediction_key",
    "near_key",
    "VERDICT_SAMPLES",
    "TooCostly",
]

VERDICT_SAMPLES = 25e6
"""Most bead sample points (:func:`loadpath.stiffness.model.sample_count`) a body's beads in either
file may take for the verdict to predict it on every run (a prediction the cache holds costs nothing and is always used).
Compare's model at 0.1 mm: the shipped example 7.9 million (2 s a prediction), a 40-layer 8 mm
L-bracket at 30 % gyroid 4.1 million (1 s); the specimen's outline 20 mm thick (100 layers) 80
million, 30-60 s a prediction, longer than the run: the verdict says so and ``loadpath compare``
predicts it.  (Since the sampling tries each point's previous element first, 2026-12-07: ``loadpath
compare`` of that specimen and its output, both predictions, 24 s on a machine where the run itself
takes 7 s; still longer than the run.)"""


class TooCostly(LoadpathError):
    """The verdict's prediction would exceed :data:`VERDICT_SAMPLES` (not an error of the run).

    Attributes
    ----------
    samples : float
        The estimate of the costlier file.
    """

    def __init__(self, message: str, samples: float) -> None:
        super().__init__(message)
        self.samples = samples


@dataclass(frozen=True)
class BodyChange:
    """One body before and after.

    Attributes
    ----------
    name : str
    compliance_before, compliance_after : float, N mm
    mass_before, mass_after : float, g
    failure_before, failure_after : float or None
        First-ply failure: the load factor (multiple of the body's applied load).
    failure_load_before, failure_load_after : float or None, N
        The same as a load (``load factor x applied load``).
    energy_ratio : (m,) float
        Strain energy density after over before, per element of :attr:`mesh` (below 1: the element
        works less for the same load, i.e. the part is stiffer there); NaN where nothing is strained.
    mesh : MeshData
        The model's mesh of the body (:func:`loadpath.stiffness.model.body_mesh`).
    """

    name: str
    compliance_before: float
    compliance_after: float
    mass_before: float
    mass_after: float
    failure_before: float | None = field(default=None, kw_only=True)
    failure_after: float | None = field(default=None, kw_only=True)
    failure_load_before: float | None = field(default=None, kw_only=True)
    failure_load_after: float | None = field(default=None, kw_only=True)
    energy_ratio: np.ndarray = field(repr=False)
    mesh: object = field(repr=False)


@dataclass(frozen=True)
class StiffnessChange:
    """The predicted change of the part: ``loadpath compare``'s output row against the slicer's.

    Attributes
    ----------
    absolute : float
        ``c_before / c_after - 1`` (compliance summed over the bodies): +0.08 is 8 % stiffer
        (``relative_stiffness - 1``).
    same_mass : float
        ``(c m)_before / (c m)_after - 1``: the gain per gram of material
        (``relative_specific_stiffness - 1``).
    failure_load : float or None
        ``F_after / F_before - 1`` with ``F`` the failure load of the weakest body (the smallest load
        factor), first ply (``relative_failure_load - 1``).
    failure_load_same_mass : float or None
        ``(F / m)_after / (F / m)_before - 1`` (``relative_failure_load_per_mass - 1``).
    label : str
        What the figures cover (the failure model and the card's material).
    bodies : tuple of BodyChange
    seconds : float
    """

    absolute: float
    same_mass: float
    failure_load: float | None = None
    failure_load_same_mass: float | None = None
    label: str = "stiffness only"
    bodies: tuple[BodyChange, ...] = ()
    seconds: float = 0.0


@dataclass(frozen=True)
class _Predicted:
    """What the verdict keeps of one body's prediction and its first-ply failure: a cache entry."""

    compliance: float
    mass: float
    energy_density: np.ndarray
    failure: float
    failure_load: float
    mesh: object = None
    """The mesh it was solved on (kept with it: a run whose predictions are all in the cache meshes nothing)."""


def prediction_key(
    fea_key: str, deposits: Deposits | Stack, options: StiffnessOptions, card: MaterialCard | None
) -> str:
    """Key of one body's prediction in the cache: everything the prediction and its failure load read.

    ``fea_key`` (:func:`loadpath.cache.fea_key`) names the resolved body (its slabs, analysis kind,
    load case and supports), from which the model's mesh is made with the options' pitch and mesh
    size; the deposits enter by their bytes, part by part (any changed bead is another key), the
    options and the card by their repr; :func:`loadpath.cache.code_stamp` and the stiffness model's
    own sources (:func:`loadpath.cache.source_stamp`) name the code.
    """
    from loadpath.cache import code_stamp, digest, source_stamp

    head: list[bytes | str] = ["prediction", code_stamp(), source_stamp("stiffness"), fea_key]
    head += [repr(options), repr(card)]

    names = ("start", "end", "z0", "height", "volume", "layer", "role")
    return digest([*head, *_field_bytes(deposits, names)])


NEAR_BEADS = 400_000
"""Most beads kept for a near match (:class:`loadpath.stiffness.near.Beads`, 21 bytes each; a larger
file matches exactly only)."""


NEAR_KEEP = 12
"""Most predictions kept under one near key.  The key names layers and roles, so the slicer's file
and every layout a run judges share it (``density = "auto"`` with the solid choice: up to 9); only a
summary of each is kept there (:func:`loadpath.stiffness.near.summary`), its beads under its
exact key (``near-beads``)."""


def _parts(deposits: Deposits | Stack) -> Iterator[Deposits]:
    """A :class:`Stack`'s parts one at a time (made as they are read), or the one :class:`Deposits`."""
    yield from (deposits if isinstance(deposits, Stack) else (deposits,))


def _field_bytes(deposits: Deposits | Stack, names: tuple[str, ...]) -> Iterator[bytes | str]:
    """What a key reads of the beads, part by part: each named field's dtype, shape and bytes."""
    for dep in _parts(deposits):
        for name in names:
            a = np.ascontiguousarray(getattr(dep, name))
            yield f"{name} {a.dtype.str} {a.shape}"
            yield a.tobytes()


def near_key(
    fea_key: str, deposits: Deposits | Stack, options: StiffnessOptions, card: MaterialCard | None
) -> str:
    """Key of a prediction's beads for a near match: :func:`prediction_key`'s, with the beads named by
    their layers and roles at their bottoms and heights only (:func:`loadpath.stiffness.near.group_bytes`:
    not their count or order; where their material lies is compared,
    :func:`loadpath.stiffness.near.match`)."""
    from loadpath.cache import code_stamp, digest, source_stamp

    head = ["prediction near", code_stamp(), source_stamp("stiffness"), fea_key, repr(options), repr(card)]
    deps = list(_parts(deposits))
    cols = [np.concatenate([getattr(d, f) for d in deps]) if deps else np.zeros(0)
            for f in ("layer", "role", "z0", "height")]
    return digest([*head, group_bytes(*cols)])


def _keys(  # type: ignore[no-untyped-def]
    key: str, deposits: Deposits | Stack, options: StiffnessOptions, card
) -> tuple[str, str]:
    """The beads' :func:`prediction_key` and :func:`near_key` (made once for a lookup and the keep
    after it)."""
    return prediction_key(key, deposits, options, card), near_key(key, deposits, options, card)


def _lookup(cache, keys: tuple[str, str], deposits: Deposits | Stack):  # type: ignore[no-untyped-def]
    """The cache's prediction of these beads: under their exact key (``keys``: :func:`_keys`), else the
    one kept under their near key when its beads lay the same material
    (:func:`loadpath.stiffness.near.match`); None if neither."""
    hit = cache.get("prediction", keys[0])
    if isinstance(hit, _Predicted):
        return hit
    if sum(len(d) for d in _parts(deposits)) > NEAR_BEADS:
        return None
    beads = None
    for key, kept in cache.near("near", keys[1]):
        beads = Beads.of(_parts(deposits)) if beads is None else beads
        if not (isinstance(kept, tuple) and agrees(kept, beads)):
            continue
        other = cache.get("near-beads", key)
        if isinstance(other, Beads) and match(other, beads):
            hit = cache.get("prediction", key)
            if not isinstance(hit, _Predicted):
                return None
            cache.put("prediction", keys[0], hit)  # these beads' own key: found at once from now on
            return hit
    return None


def _keep(  # type: ignore[no-untyped-def]
    cache, keys: tuple[str, str], deposits: Deposits | Stack, value
) -> None:
    """Keep a prediction under its exact key and, for a file of at most :data:`NEAR_BEADS` beads, its
    beads under their near key (``keys``: :func:`_keys`; :meth:`loadpath.cache.Cache.keep_near`, the beads themselves under
    ``near-beads``)."""
    cache.put("prediction", keys[0], value)
    if sum(len(d) for d in _parts(deposits)) <= NEAR_BEADS:
        beads = Beads.of(_parts(deposits))
        cache.put("near-beads", keys[0], beads, evict=False)
        cache.keep_near("near", keys[1], keys[0], summary(beads), most=NEAR_KEEP)


def _cached(deposits: Deposits, options: StiffnessOptions, card, cache, key: str) -> bool:  # type: ignore[no-untyped-def]
    """The cache holds this prediction (or one of beads near enough, :func:`_lookup`)."""
    if cache is None or not key:
        return False
    return _lookup(cache, _keys(key, deposits, options, card), deposits) is not None


_PAIR: list = []
"""What :func:`_solve_nth` reads in a forked worker: ``(rb, deposits, options, card, mesh)`` per solve
(set by :func:`_predict_pair` before it forks; only the index and the figures cross processes)."""


def _solve_nth(k: int) -> tuple[float, float, np.ndarray, float, float]:
    """Solve :data:`_PAIR`'s ``k``-th prediction: compliance, mass, energy density, load factor, failure load."""
    rb, deposits, options, card, mesh = _PAIR[k]
    p, f = solve_body(rb, deposits, options, card, mesh)
    return p.compliance, p.mass, p.energy_density, f.load_factor, f.failure_load


def _predict_pair(  # type: ignore[no-untyped-def]
    rb, meshes: dict, pair: tuple, options: StiffnessOptions, card, cache, key: str, workers: int
) -> tuple[tuple[_Predicted, _Predicted], int]:
    """A body's two predictions (the slicer's beads, the output's) and how many were solved.

    Each is read from the cache (:func:`_lookup`: its exact key, else a near match) when it holds it,
    else solved and kept (:func:`_keep`).
    The body's mesh is made (:func:`~loadpath.stiffness.model.body_mesh`) only to solve; a cached
    prediction brings its own, which ``meshes`` then holds for a solve after it (the cache is read
    and the meshes chosen in the pair's order).  The solves then run side by side in ``workers``
    forked processes when there are two (the verdict is the run's last long stage and a solve uses
    one core), else here; a solve is the same computation in a worker: the same figures bit for bit.
    """
    from loadpath.procs import fork_map

    keys = [_keys(key, dep, options, card) if cache is not None and key else None for dep in pair]
    out: list[_Predicted | None] = [None, None]
    todo: list[tuple[int, object]] = []
    for i, (dep, k) in enumerate(zip(pair, keys, strict=True)):
        if k is not None:
            hit = _lookup(cache, k, dep)
            if isinstance(hit, _Predicted) and hit.mesh is not None:
                meshes.setdefault(mesh_key(rb, options), hit.mesh)
                out[i] = hit
                continue
        todo.append((i, body_mesh(rb, options, meshes)))
    _PAIR[:] = [(rb, pair[i], options, card, mesh) for i, mesh in todo]
    try:
        solved = fork_map(_solve_nth, list(range(len(todo))), workers)
    finally:
        _PAIR.clear()
    for (i, mesh), got in zip(todo, solved, strict=True):
        out[i] = _Predicted(*got, mesh)
        k = keys[i]
        if k is not None:
            _keep(cache, k, pair[i], out[i])
    return (out[0], out[1]), len(todo)


class _CachedLayers:
    """The bead neighbour search's layers (:func:`loadpath.stiffness.beads.layer_store`) in the run cache.

    A re-slice that moves a few beads of one layer changes both predictions' keys; the other layers'
    neighbours (about half of a prediction's time) are still those of the last run.
    """

    def __init__(self, cache) -> None:  # type: ignore[no-untyped-def]
        from loadpath.cache import code_stamp, source_stamp

        self.cache = cache
        self.stamp = f"{code_stamp()} {source_stamp('stiffness')}"
        self.kept = 0

    def _key(self, key: bytes) -> str:
        from loadpath.cache import digest

        return digest(["bead layer", self.stamp, key])

    def get(self, key: bytes):  # type: ignore[no-untyped-def]
        hit = self.cache.get("beads", self._key(key))
        return hit if isinstance(hit, tuple) and len(hit) == 5 else None

    def put(self, key: bytes, value: tuple) -> None:
        self.kept += self.cache.put("beads", self._key(key), value, evict=False)


def predicted_change(
    analyses: Mapping[str, object],
    program,
    output,
    object_codes: Mapping[str, int],
    filament_diameter: float,
    loadcase=None,
    options: StiffnessOptions | None = None,
    cache=None,
    fea_keys: Mapping[str, str] | None = None,
    budget: float | None = None,
    workers: int = 1,
) -> StiffnessChange:
    """Predict the part's stiffness and failure load before and after a run, as ``loadpath compare`` does.

    Parameters
    ----------
    analyses : mapping of str -> Analysis
        The run's FEA per body: its resolved body (the load case on the part) is reused, its mesh
        is not (the model meshes the body its own way, :func:`loadpath.stiffness.model.body_mesh`).
    program : Program
        The slicer's G-code.
    output : Program or callable
        The run's G-code (parsed back: the beads as the printer lays them), or a function of no
        argument that parses it: called only once the slicer's beads are within the budget (a
        1000-layer file's output, 100 MB of text, is 1.1 GB parsed; issue 17's 1 GB peak).
    object_codes : mapping of str -> int
        Object name -> index into ``program.objects`` (the output labels its objects alike).
    filament_diameter : float, mm
        Of the slicer's file as its geometry reads it (``PipelineResult.geometry``), as ``compare`` does.
    loadcase : LoadCase, optional
        Its ``[material] printed`` names the card when the file does not.
    options : StiffnessOptions, optional
        Default ``compare``'s (``StiffnessOptions()``).
    cache : loadpath.cache.Cache, optional
        Keeps each prediction under :func:`prediction_key` (with ``fea_keys``).
    fea_keys : mapping of str -> str, optional
        Object name -> the key of its analysis in the cache (``PipelineResult.fea_keys``); a body
        without one is predicted, not kept.
    budget : float, optional
        Most bead sample points of one body's prediction not in the cache (default
        :data:`VERDICT_SAMPLES`).
    workers : int
        Processes for a body's two predictions when neither is in the cache: 2 or more solves them
        side by side in forked workers (:func:`loadpath.procs.fork_map`), 1 one after the other;
        the same figures either way.

    Returns
    -------
    StiffnessChange

    Raises
    ------
    TooCostly
        A file over the budget, before any solve.
    LoadpathError
        A body extrudes nothing, or a solve fails its residual check.
    """
    t0 = time.perf_counter()
    budget = VERDICT_SAMPLES if budget is None else budget
    options, card, _ = file_card(program.config, loadcase, options)
    layers = _CachedLayers(cache) if cache is not None and fea_keys else None
    meshes: dict = {}
    bodies = []
    forked = False
    with layer_store(layers) if layers is not None else nullcontext():
        for name, an in analyses.items():
            rb = an.resolved
            key = (fea_keys or {}).get(name, "")
            code = object_codes[name]
            before = from_program(program, code, filament_diameter)
            _within_budget(before, options, card, cache, key, budget)  # before the output is parsed
            if callable(output):
                output = output()
            after = from_program(output, _same_object(program, output, code), filament_diameter)
            _within_budget(after, options, card, cache, key, budget)
            (p0, p1), solved = _predict_pair(rb, meshes, (before, after), options, card, cache, key, workers)
            forked |= solved > 1 and workers > 1
            bodies.append(_body(name, p0, p1, p0.mesh))
    if layers is not None and (layers.kept or forked):  # the workers kept layers this process did not count
        cache.evict()
    return _summary(bodies, card, t0)


def _within_budget(dep: Deposits, options, card, cache, key: str, budget: float) -> None:  # type: ignore[no-untyped-def]
    """Raise :class:`TooCostly` for beads over ``budget`` sample points that the cache does not hold
    (before any solve)."""
    n = sample_count(dep, options)
    if n > budget and not _cached(dep, options, card, cache, key):
        raise TooCostly(
            f"{n / 1e6:.0f} million bead samples, over the verdict's budget of {budget / 1e6:.0f} million, "
            "not predicted on every run",
            n,
        )


def _same_object(program, output, code: int) -> int:  # type: ignore[no-untyped-def]
    """The output's code of the slicer's object ``code`` (the splicer keeps the labels; -1: unlabelled)."""
    if code < 0:
        return code
    label = program.objects[code]
    if label not in output.objects:
        raise LoadpathError(f"the output has no object {label!r}: its beads cannot be compared with the slicer's")
    return output.objects.index(label)


def change_from_results(before, after, seconds: float = 0.0) -> StiffnessChange:
    """The change between two files ``compare`` has evaluated (no solve).

    Parameters
    ----------
    before, after : FileResult
        :func:`loadpath.stiffness.compare.evaluate_file` of the slicer's file and the run's output,
        bodies in the same order, on the same meshes.
    seconds : float
        What the two evaluations took.
    """
    bodies = []
    for b0, b1, f0, f1 in zip(before.predictions, after.predictions, before.failures, after.failures, strict=True):
        p0 = _Predicted(b0.compliance, b0.mass, b0.energy_density, f0.load_factor, f0.failure_load, b0.mesh)
        p1 = _Predicted(b1.compliance, b1.mass, b1.energy_density, f1.load_factor, f1.failure_load, b1.mesh)
        bodies.append(_body(b0.name, p0, p1, b0.mesh))
    return _summary(bodies, after.card, 0.0, seconds)


def _body(name: str, p0: _Predicted, p1: _Predicted, mesh) -> BodyChange:  # type: ignore[no-untyped-def]
    e0, e1 = p0.energy_density, p1.energy_density
    if e0.shape != e1.shape:  # two cached predictions of other meshes: no per-element ratio
        e1 = np.full(e0.shape, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(e0 > 0, e1 / e0, np.nan)
    return BodyChange(
        name, p0.compliance, p1.compliance, p0.mass, p1.mass, energy_ratio=ratio, mesh=mesh,
        failure_before=p0.failure, failure_after=p1.failure,
        failure_load_before=p0.failure_load, failure_load_after=p1.failure_load,
    )


def _summary(bodies: list[BodyChange], card: MaterialCard, t0: float, seconds: float | None = None) -> StiffnessChange:
    """The part's change from its bodies', as ``compare``'s row (:func:`loadpath.stiffness.compare.row`)."""
    c0 = sum(b.compliance_before for b in bodies)
    c1 = sum(b.compliance_after for b in bodies)
    m0 = sum(b.mass_before for b in bodies)
    m1 = sum(b.mass_after for b in bodies)
    absolute = c0 / c1 - 1.0 if c1 > 0 else float("nan")
    same_mass = (c0 * m0) / (c1 * m1) - 1.0 if c1 > 0 and m1 > 0 else float("nan")
    # the part fails when its weakest body does (the smallest load factor), at that body's load
    w0 = min(bodies, key=lambda b: b.failure_before)
    w1 = min(bodies, key=lambda b: b.failure_after)
    F0, F1 = w0.failure_load_before, w1.failure_load_after
    ok = np.isfinite(F0) and np.isfinite(F1) and F0 > 0
    fl = F1 / F0 - 1.0 if ok else float("nan")
    fl_mass = (F1 * m0) / (F0 * m1) - 1.0 if ok and m1 > 0 else float("nan")
    label = f"first-ply failure, {card.key.upper()} card"
    secs = time.perf_counter() - t0 if seconds is None else seconds
    return StiffnessChange(absolute, same_mass, fl, fl_mass, label, bodies=tuple(bodies), seconds=secs)
