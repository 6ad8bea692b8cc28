"""The engine registry: every path engine, and what the pipeline must know about it, in one place.

An :class:`Engine` entry names the engine and says

- where its ``generate(inp: EngineInput, **options) -> Toolpaths`` lives (imported on first use,
  so naming the engines imports neither numba nor an engine);
- its options (a frozen dataclass, :meth:`Engine.options_class`) and which of the user's settings
  it takes (``settings``: the swarm's ``K``);
- whether it lays the staggered copy of a run of identical layers itself (:meth:`Engine.lays_phase`:
  from seeds moved on by half a pitch, option ``phase``) or the pipeline shifts its paths sideways
  (:func:`loadpath.pipeline.paths.stagger`);
- its warm-up (compile or load compiled kernels before worker processes fork);
- which machine facts (:class:`Machine`: nozzle, bead-width range, flow width) it receives; the
  pipeline hands them down and :func:`generate` passes an engine the ones it declares.

The command line, the settings schema (and the Cura plugin's schema generated from it), the load
case's ``[toolpath] engine`` and the demo read the names from :data:`NAMES`, a live view: adding an
engine is one :func:`register` call.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

from loadpath.errors import SettingsError
from loadpath.toolpath import EngineInput, Toolpaths

__all__ = [
    "Machine",
    "Engine",
    "register",
    "unregister",
    "get",
    "NAMES",
    "DEFAULT",
    "SPARSE_DEFAULT",
    "SPARSE_CHOICES",
    "for_sparse",
    "SOLID_FIRST",
    "first_on_solid",
    "generate",
    "warm_up",
]


@dataclass(frozen=True)
class Machine:
    """What the printer and the slicer's settings allow, as an engine may need it.

    Attributes
    ----------
    nozzle : float, mm
        Nozzle diameter.
    width_range : (float, float)
        Narrowest and widest bead, as multiples of ``nozzle`` (the splicer clamps to the same range).
    flow_width : float or None, mm
        The slicer's bead width at the nominal pitch; None: the pitch (solid infill).
    """

    nozzle: float = 0.4
    width_range: tuple[float, float] = (0.6, 1.6)
    flow_width: float | None = None


def _load(dotted: str) -> Any:
    module, _, name = dotted.partition(":")
    obj = importlib.import_module(module)
    return getattr(obj, name) if name else obj


@dataclass(frozen=True)
class Engine:
    """One registered path engine.

    Attributes
    ----------
    name : str
        What the user types (``--engine``, ``[toolpath] engine``).
    module : str
        Import path of the module whose ``generate(inp, **options)`` runs the engine.
    options : str
        ``"module:Class"`` of its frozen options dataclass (imported on use).
    summary : str
        One line for help texts.
    settings : tuple of str
        User settings (:class:`loadpath.plugin.settings.Settings` fields) passed to the engine as
        options of the same name.
    phase : callable
        ``phase(options) -> bool``: whether, run with these options, it lays the staggered copy
        itself (option ``phase = 0.5``).
    warm_up : str or None
        ``"module:function"`` compiling what the engine compiles, run before workers fork.
    machine : tuple of str
        :class:`Machine` fields the engine receives as options of the same name.
    density : bool
        Whether it lays a density field itself (``inp.density``); otherwise :func:`generate` runs
        it once per zone of the field at the zone's pitch.
    linking : mapping
        :class:`loadpath.engines.linking.LinkOptions` fields its solid-infill paths are linked with
        (the shared linking stage's defaults otherwise, and always for sparse infill).
    """

    name: str
    module: str
    options: str
    summary: str
    settings: tuple[str, ...] = ()
    phase: Callable[[Mapping[str, Any]], bool] = lambda options: False
    warm_up: str | None = None
    machine: tuple[str, ...] = ()
    density: bool = False
    linking: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        unknown = set(self.machine) - {f.name for f in fields(Machine)}
        if unknown:
            raise SettingsError(f"engine {self.name!r}: unknown machine facts {', '.join(sorted(unknown))}")

    def lays_phase(self, options: Mapping[str, Any]) -> bool:
        """Whether the engine, run with ``options``, lays a staggered copy itself (option ``phase``)."""
        return bool(self.phase(options))

    def options_class(self) -> type:
        """Return the engine's frozen options dataclass."""
        cls: type = _load(self.options)
        return cls

    def machine_options(self, machine: Machine | None) -> dict[str, Any]:
        """Return the machine facts this engine receives, as options (None values left out)."""
        if machine is None:
            return {}
        values = {k: getattr(machine, k) for k in self.machine}
        return {k: v for k, v in values.items() if v is not None}


_REGISTRY: dict[str, Engine] = {}


class _Names(Sequence[str]):
    """``extra`` and the registered engine names, in registration order; a live view of the registry."""

    def __init__(self, extra: tuple[str, ...] = ()) -> None:
        self.extra = extra

    def __getitem__(self, i: Any) -> Any:
        return (*self.extra, *_REGISTRY)[i]

    def __len__(self) -> int:
        return len(self.extra) + len(_REGISTRY)

    def __iter__(self) -> Iterator[str]:
        return iter((*self.extra, *_REGISTRY))

    def __contains__(self, name: object) -> bool:
        return name in self.extra or name in _REGISTRY

    def __repr__(self) -> str:
        return repr((*self.extra, *_REGISTRY))


NAMES: Sequence[str] = _Names()
"""Registered engine names (first: the default), always current."""
SPARSE_CHOICES: Sequence[str] = _Names(("auto",))
"""What ``sparse_engine`` takes: ``auto`` (:func:`for_sparse`) or a registered name, always current."""


def register(engine: Engine) -> Engine:
    """Add an engine (a name registered twice is an error)."""
    if engine.name in _REGISTRY:
        raise SettingsError(f"an engine named {engine.name!r} is registered already")
    _REGISTRY[engine.name] = engine
    return engine


def unregister(name: str) -> None:
    """Remove an engine (tests that register one of their own)."""
    _REGISTRY.pop(name, None)


def get(name: str) -> Engine:
    """Return the engine called ``name`` (one-line :class:`SettingsError` when none is)."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise SettingsError(f"engine = {name!r} is unknown; use one of {', '.join(_REGISTRY)}") from None


def generate(engine: str, inp: EngineInput, machine: Machine | None = None, **options: Any) -> Toolpaths:
    """Run the named engine on one region.

    Parameters
    ----------
    engine : str
        A registered name (:data:`NAMES`).
    inp : EngineInput
    machine : Machine, optional
        Machine facts; the engine receives those it declares (explicit ``options`` win).
    **options
        Engine options (``K`` for the swarm, ...).

    Returns
    -------
    Toolpaths
    """
    entry = get(engine)
    module = importlib.import_module(entry.module)
    params = {**entry.machine_options(machine), **options}
    if inp.density is not None and not entry.density:
        return _zoned(module, inp, params)
    result: Toolpaths = module.generate(inp, **params)
    return result


DENSITY_LEVELS = 5
"""Pitch levels of a density field (zones); engine parameter ``density_levels``."""


def _zoned(module: Any, inp: EngineInput, params: dict[str, Any]) -> Toolpaths:
    """Run the engine once per zone of the density field (:mod:`loadpath.engines`' docstring)."""
    from dataclasses import replace

    from loadpath.engines.zones import zones

    params = dict(params)
    levels = int(params.pop("density_levels", DENSITY_LEVELS))
    scale = inp.pitch / inp.density.base_pitch
    paths: list[Any] = []
    runs = []
    for z in zones(inp.density, inp.region, levels):
        if z.region.is_empty or z.region.area < (z.pitch * scale) ** 2:
            continue
        sub = replace(inp, region=z.region, pitch=z.pitch * scale, density=None)
        tp: Toolpaths = module.generate(sub, **params)
        paths.extend(tp.paths)
        area = round(float(z.region.area), 2)
        runs.append({"pitch": round(sub.pitch, 4), "area": area, "paths": len(tp.paths)})
    return Toolpaths(tuple(paths), {"zones": runs, "density_mean": inp.density.mean})


def warm_up(engine: str) -> None:
    """Run the engine's warm-up, if it has one (before forking workers that would each compile)."""
    entry = get(engine)
    if entry.warm_up:
        _load(entry.warm_up)()


# ------------------------------------------------------------------------------ the engines

DEFAULT = "swarm"
"""The engine named by default: it lays the solid infill the level sets give way on (:data:`SOLID_FIRST`).

The level sets retract 3-6x less on solid infill, but where a part bends its internal solid
layers' first ply fails at the level sets' ends on the neutral-axis cut: with the level sets on
all solid infill, ``bench_sparse.py --thickness 12`` lost failure load on 8 of 20 files (the 3-point
beam at CuraEngine 20 % 3.004 -> 2.193x the slicer's; ``benchmarks/printability_results.md``,
eleventh round).  So the level sets are tried first and the swarm lays each layer whose fit that
cut crosses; naming an engine (``--engine swarm``) lays everything with it.  On other bent parts
the level sets are the stronger (2.4 mm parts printed solid), so where some layers gave way the run
lays both layouts and keeps the one the mechanics model predicts better
(:mod:`loadpath.plugin.solid_choice`).
"""

SPARSE_DEFAULT = "levelset"
"""The engine for sparse infill when the user names none (:func:`for_sparse`).

The level sets lead the swarm on sparse infill at the same mass.  ``benchmarks/bench_sparse.py
--thickness 12 --variants density`` (five parts, PrusaSlicer gyroid and CuraEngine grid at 20 % and
40 %: 20 files, 2026-12-05, over the slicer's file): stiffer on all 20 (20 %: 1.33-1.92x against
the swarm's 1.18-1.86x), a higher failure load on 16 (the swarm's is higher on the 40 % L-bracket
and shelf, both slicers), no more sparse retractions per layer on 14, no longer print time on 12,
a smaller output on all 20.  Ten 2.4 mm parts at 40 % (``benchmarks/printability_results.md``,
sixth round): stiffer and stronger on all ten, 16-64 retractions against 66-192 on PrusaSlicer's
five.  The 40-layer 30 % gyroid gusset of ``bench_latency.py``, swarm on solid and level sets on
sparse against the swarm on both: stiffness 2.127 against 2.092x the slicer's, failure load 3.03
against 2.87x, 452 against 810 retractions (the slicer's 207), 10.5 against 14.4 s.
"""


SOLID_FIRST = "levelset"
"""The engine tried first on solid infill when the user names none (:func:`first_on_solid`).

Run with ``give_way``: where a jump of the stress direction cuts a layer's fit along more than
:data:`loadpath.engines.levelset.GIVE_WAY` (a bending part's neutral axis) it lays nothing, and
:data:`DEFAULT` lays that layer.
"""


def first_on_solid(engine_chosen: bool) -> tuple[str, dict[str, Any]] | None:
    """The engine tried first on solid infill and its options: :data:`SOLID_FIRST` with
    ``give_way``, unless the user named an engine.

    >>> first_on_solid(False), first_on_solid(True)
    (('levelset', {'give_way': True}), None)
    """
    return None if engine_chosen else (get(SOLID_FIRST).name, {"give_way": True})


def for_sparse(sparse_engine: str, engine: str, engine_chosen: bool) -> str:
    """The engine that lays sparse infill.

    ``sparse_engine`` when it names one; ``"auto"``: the engine the user chose for the rest
    (``engine_chosen``: ``engine`` was set, not left at its default), else :data:`SPARSE_DEFAULT`.

    Examples
    --------
    >>> for_sparse("auto", "swarm", False), for_sparse("auto", "swarm", True)
    ('levelset', 'swarm')
    >>> for_sparse("streamlines", "swarm", True)
    'streamlines'
    """
    if sparse_engine != "auto":
        return get(sparse_engine).name
    return get(engine).name if engine_chosen else SPARSE_DEFAULT

register(
    Engine(
        name="swarm",
        module="loadpath.engines.swarm",
        options="loadpath.engines.swarm.options:SwarmOptions",
        summary="the swarm paper's agents (Guidetti et al. 2024)",
        settings=("K",),
        phase=lambda options: True,
        warm_up="loadpath.engines.swarm.warmup:warm_up",
    )
)
register(
    Engine(
        name="streamlines",
        module="loadpath.engines.streamlines",
        options="loadpath.engines.streamlines.params:StreamlineOptions",
        summary="streamlines of the principal stress (the thesis)",
        # faithful streamlines (lattice or element-centroid seeds) have no seeds to move on
        phase=lambda options: options.get("mode", "default") == "default",
        machine=("nozzle", "width_range"),
    )
)
register(
    Engine(
        name="levelset",
        module="loadpath.engines.levelset",
        options="loadpath.engines.levelset:LevelSetOptions",
        summary="level sets of a field fitted to the principal stress (the thesis's Ch. 3)",
        phase=lambda options: True,
        density=True,
        machine=("flow_width",),
        warm_up="loadpath.engines.levelset:warm_up",
        # level sets that leave a cut at 45 degrees reach the edge at a few degrees (a bending
        # part's tension and compression faces): each end's link runs along the edge beside the
        # path converging on it, for up to 24 pitches (``benchmarks/bench_printability.py``); and
        # the links are chosen all at once too, 200 branch-and-bound nodes a solve
        # (loadpath.engines.exact_links; not for the swarm's layers, 2-5x as many paths and
        # candidates, where testing every candidate cost more than the runs it saved: 86 -> 78)
        linking={"wedge": 24.0, "max_edge_link": 24.0, "exact": 200},
    )
)
"""The level-set engine (:mod:`loadpath.engines.levelset`): edge-to-edge paths that link into zig-zags."""
