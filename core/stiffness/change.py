"""What a run changed in the part's predicted response: the one function a run's verdict calls.

:func:`predicted_change` compares the slicer's part with loadpath's under the run's own load case,
with the stiffness model of :func:`loadpath.stiffness.predict` on the run's own FEA mesh (no new
mesh), so it costs two material samplings and two solves per body.  Given the file's material card
(:func:`loadpath.stiffness.card_for`) it also predicts the failure-load change: first-ply failure
(:func:`loadpath.stiffness.strength.first_failure`) on those same two solves, no further solve.
Without a card it predicts **stiffness only** and says so in :attr:`StiffnessChange.label`.

With a :class:`loadpath.cache.Cache` and the bodies' FEA keys, each of the two predictions (the
slicer's deposits, loadpath's) is kept under :func:`prediction_key`: the deposits' own bytes, the
analysis (its key names mesh, load case and supports), the options, the card and the code.  A
re-export with other speeds or temperatures deposits the same beads, so it re-uses both; a run with
other loadpath settings still re-uses the slicer's.
"""

from __future__ import annotations

import dataclasses
import time
from contextlib import nullcontext
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from loadpath.stiffness.beads import layer_store
from loadpath.stiffness.cards import MaterialCard
from loadpath.stiffness.deposits import Deposits, Stack, from_program, from_toolpaths
from loadpath.stiffness.predict import StiffnessOptions, predict
from loadpath.stiffness.strength import first_failure

__all__ = [
    "StiffnessChange",
    "BodyChange",
    "predicted_change",
    "new_deposits",
    "prediction_key",
    "VERDICT_RESOLUTION",
]

VERDICT_RESOLUTION = 0.5
"""Bead sampling step for the verdict, mm: the run's FEA elements are several mm across.  On the
12-layer shelf bracket with a 50 mm cut-out (streamlines, solid,sparse): 0.1 mm gives +1.49 % in
5.4 s, 0.5 mm +1.51 % in 0.4 s, 1.0 mm +1.33 % in 0.4 s."""


@dataclass(frozen=True)
class BodyChange:
    """One body before and after.

    Attributes
    ----------
    name : str
    compliance_before, compliance_after : float, N mm
    mass_before, mass_after : float, g
    failure_before, failure_after : float or None, N
        First-ply failure load (None: no card given).
    energy_ratio : (m,) float
        Strain energy density after over before, per element of :attr:`mesh` (below 1: the element
        works less for the same load, i.e. the part is stiffer there); NaN where nothing is strained.
    mesh : MeshData
    """

    name: str
    compliance_before: float
    compliance_after: float
    mass_before: float
    mass_after: float
    failure_before: float | None = field(default=None, kw_only=True)
    failure_after: float | None = field(default=None, kw_only=True)
    energy_ratio: np.ndarray = field(repr=False)
    mesh: object = field(repr=False)


@dataclass(frozen=True)
class StiffnessChange:
    """The predicted change of the part.

    Attributes
    ----------
    absolute : float
        ``c_before / c_after - 1`` (compliance summed over the bodies): +0.08 is 8 % stiffer.
    same_mass : float
        ``(c m)_before / (c m)_after - 1``: the gain per gram of material.
    failure_load : float or None
        The change of the failure load, ``F_after / F_before - 1`` with ``F`` the load at which the
        first body fails (its first ply), the bodies' load cases scaled together (None: no card).
    failure_load_same_mass : float or None
        ``(F / m)_after / (F / m)_before - 1``.
    label : str
        What the figures cover (``"stiffness only"`` without a card, else the card's material).
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
    """What the verdict keeps of one :func:`predict` (and its first-ply failure): a cache entry."""

    compliance: float
    mass: float
    energy_density: np.ndarray
    failure: float | None


def prediction_key(
    fea_key: str, deposits: Deposits | Stack, options: StiffnessOptions, card: MaterialCard | None
) -> str:
    """Key of one body's prediction in the cache: everything :func:`predict` and the failure load read.

    ``fea_key`` (:func:`loadpath.cache.fea_key`) names the analysis whose mesh, load case and supports
    are reused; the deposits enter by their bytes, part by part (any changed bead is another key),
    the options and the card by their repr; :func:`loadpath.cache.code_stamp` and the stiffness
    model's own sources (:func:`loadpath.cache.source_stamp`) name the code.
    """
    from loadpath.cache import code_stamp, digest, source_stamp

    head: list[bytes | str] = ["prediction", code_stamp(), source_stamp("stiffness"), fea_key]
    head += [repr(options), repr(card)]

    def parts() -> Iterator[bytes | str]:  # a Stack's parts one at a time
        yield from head
        for dep in deposits if isinstance(deposits, Stack) else (deposits,):
            for name in ("start", "end", "z0", "height", "volume", "layer", "role"):
                a = np.ascontiguousarray(getattr(dep, name))
                yield f"{name} {a.dtype.str} {a.shape}"
                yield a.tobytes()

    return digest(parts())


def _predict(an, deposits: Deposits | Stack, options: StiffnessOptions, card, cache, key: str) -> _Predicted:
    """One body's prediction: from the cache under ``key`` when it holds it, else solved and kept."""
    k = prediction_key(key, deposits, options, card) if cache is not None and key else None
    if k is not None:
        hit = cache.get("prediction", k)
        if isinstance(hit, _Predicted):
            return hit
    p = predict(an.resolved, deposits, options, an.mesh)
    failure = None if card is None else first_failure(p, card).load_factor
    out = _Predicted(p.compliance, p.mass, p.energy_density, failure)
    if k is not None:
        cache.put("prediction", k, out)
    return out


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


@dataclass(frozen=True)
class _UnitBeads:
    """The beads of one replaced unit, made when read (a :class:`~loadpath.stiffness.deposits.Stack`
    part: the engine's paths are the pipeline's anyway, their beads would be a second copy)."""

    paths: object
    z: float
    height: float
    layer: int
    volume: float

    def __call__(self) -> Deposits:
        dep = from_toolpaths(self.paths, self.z, self.height, self.layer)
        if dep.total_volume > 0:
            dep = dataclasses.replace(dep, volume=dep.volume * (self.volume / dep.total_volume))
        return dep


def new_deposits(jobs: Sequence, volumes: Mapping[int, float]) -> dict[str, list]:
    """Deposits of the engine's paths on every unit whose blocks were replaced, by object name.

    The beads follow the engine's paths (:func:`~loadpath.stiffness.deposits.from_toolpaths`),
    their volume scaled to what the splicer extruded into the unit's blocks (``volumes``: block row
    -> mm³; the splicer matches the slicer's volume, a sparse block's pitch is not its flow width);
    a staggered layer prints the same paths half a pitch aside, which the model cannot tell apart.
    Each unit's are a function that makes its :class:`Deposits` (a part of a
    :class:`~loadpath.stiffness.deposits.Stack`): 3 million one-segment beads for a 100-layer
    specimen are made a few layers at a time.
    """
    out: dict[str, list] = {}
    for jr in jobs:
        for u in jr.units:
            vol = sum(volumes.get(b.block_index, 0.0) for b in u.blocks)
            if vol <= 0:
                continue
            out.setdefault(u.object, []).append(_UnitBeads(jr.paths, u.z, u.height, u.layer, vol))
    return out


def predicted_change(
    analyses: Mapping[str, object],
    program,
    object_codes: Mapping[str, int],
    replaced: set[int],
    added: Mapping[str, Sequence[Deposits]],
    filament_diameter: float,
    options: StiffnessOptions | None = None,
    card: MaterialCard | None = None,
    cache=None,
    fea_keys: Mapping[str, str] | None = None,
) -> StiffnessChange:
    """Predict the part's stiffness before and after a run.

    Parameters
    ----------
    analyses : mapping of str -> Analysis
        The run's FEA per body (its resolved load case and mesh are reused).
    program : Program
        The slicer's G-code.
    object_codes : mapping of str -> int
        Object name -> index into ``program.objects``.
    replaced : set of int
        Rows of ``program.blocks`` the run replaced.
    added : mapping of str -> sequence of Deposits or functions making them
        The new beads per object (:func:`new_deposits`), after the slicer's kept ones in a
        :class:`~loadpath.stiffness.deposits.Stack`.
    filament_diameter : float, mm
    options : StiffnessOptions, optional
        Default: the bead model at :data:`VERDICT_RESOLUTION`.
    card : MaterialCard, optional
        The file's material (:func:`loadpath.stiffness.card_for`): its elastic ply replaces the
        options' material and the failure load is predicted; None: stiffness only.
    cache : loadpath.cache.Cache, optional
        Keeps each prediction under :func:`prediction_key` (with ``fea_keys``).
    fea_keys : mapping of str -> str, optional
        Object name -> the key of its analysis in the cache (``PipelineResult.fea_keys``); a body
        without one is predicted, not kept.

    Returns
    -------
    StiffnessChange

    Raises
    ------
    LoadpathError
        A body extrudes nothing, or a solve fails its residual check.
    """
    t0 = time.perf_counter()
    options = StiffnessOptions(resolution=VERDICT_RESOLUTION) if options is None else options
    if card is not None:
        options = dataclasses.replace(options, material=card.elastic)
    layers = _CachedLayers(cache) if cache is not None and fea_keys else None
    with layer_store(layers) if layers is not None else nullcontext():
        args = (analyses, program, object_codes, replaced, added, filament_diameter)
        bodies = _bodies(*args, options, card, cache, fea_keys)
    if layers is not None and layers.kept:
        cache.evict()
    return _summary(bodies, card, t0)


def _bodies(  # type: ignore[no-untyped-def]
    analyses, program, object_codes, replaced, added, filament_diameter, options, card, cache, fea_keys
):
    """Each body before and after (:func:`predicted_change`)."""
    bodies = []
    for name, an in analyses.items():
        code = object_codes[name]
        before = from_program(program, code, filament_diameter)
        kept = from_program(program, code, filament_diameter, exclude_blocks=replaced)
        after = Stack((kept, *added.get(name, ())))
        key = (fea_keys or {}).get(name, "")
        # first-ply failure (with a card) on the same two solves
        p0 = _predict(an, before, options, card, cache, key)
        p1 = _predict(an, after, options, card, cache, key)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(p0.energy_density > 0, p1.energy_density / p0.energy_density, np.nan)
        f0, f1 = p0.failure, p1.failure
        bodies.append(
            BodyChange(
                name, p0.compliance, p1.compliance, p0.mass, p1.mass, ratio, an.mesh, failure_before=f0, failure_after=f1
            )
        )
    return bodies


def _summary(bodies: list[BodyChange], card: MaterialCard | None, t0: float) -> StiffnessChange:
    """The part's change from its bodies' (:func:`predicted_change`)."""
    c0 = sum(b.compliance_before for b in bodies)
    c1 = sum(b.compliance_after for b in bodies)
    m0 = sum(b.mass_before for b in bodies)
    m1 = sum(b.mass_after for b in bodies)
    absolute = c0 / c1 - 1.0 if c1 > 0 else float("nan")
    same_mass = (c0 * m0) / (c1 * m1) - 1.0 if c1 > 0 and m1 > 0 else float("nan")
    fl = fl_mass = None
    label = "stiffness only"
    if card is not None:
        # the part fails when its first body does: the smallest load factor, before and after
        lam0 = min(b.failure_before for b in bodies)
        lam1 = min(b.failure_after for b in bodies)
        ok = np.isfinite(lam0) and np.isfinite(lam1) and lam0 > 0
        fl = lam1 / lam0 - 1.0 if ok else float("nan")
        fl_mass = (lam1 * m0) / (lam0 * m1) - 1.0 if ok and m1 > 0 else float("nan")
        label = f"first-ply failure, {card.key.upper()} card"
    return StiffnessChange(
        absolute, same_mass, fl, fl_mass, label, bodies=tuple(bodies), seconds=time.perf_counter() - t0
    )
