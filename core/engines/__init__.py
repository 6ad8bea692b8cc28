"""Path engines: ``swarm`` (the swarm paper) and ``streamlines`` (the thesis).

Each engine module exposes ``generate(inp: EngineInput, **params) -> Toolpaths``.
:func:`generate` picks one by name, importing it only when used.

A spatially varying pitch (``inp.density``, :mod:`loadpath.density`) is laid by zones: the region is
split where the density field's pitch, rounded to a few levels, changes (:mod:`loadpath.engines.zones`),
and the engine fills each zone at its own pitch; the paths of all zones come back as one layer.
Inside a zone both engines' spacing terms use its pitch (the swarm's QP box and spacing, the
streamlines' seeding distance and minimum spacing), so ``l(x)`` is piecewise constant.
"""

from __future__ import annotations

import importlib
from typing import Any

from loadpath.errors import SettingsError
from loadpath.toolpath import EngineInput, Toolpaths

__all__ = ["ENGINES", "DENSITY_LEVELS", "generate"]

ENGINES = {
    "swarm": "loadpath.engines.swarm",
    "streamlines": "loadpath.engines.streamlines",
}


DENSITY_LEVELS = 5
"""Pitch levels of a density field (zones); engine parameter ``density_levels``."""


def generate(engine: str, inp: EngineInput, **params: Any) -> Toolpaths:
    """Run the named engine on one region.

    Parameters
    ----------
    engine : {"swarm", "streamlines"}
    inp : EngineInput
    **params
        Engine parameters (``K`` for the swarm, ...).

    Returns
    -------
    Toolpaths
    """
    if engine not in ENGINES:
        raise SettingsError(f"engine = {engine!r} is unknown; use one of {', '.join(ENGINES)}")
    module = importlib.import_module(ENGINES[engine])
    if inp.density is not None:
        return _zoned(module, inp, params)
    result: Toolpaths = module.generate(inp, **params)
    return result


def _zoned(module: Any, inp: EngineInput, params: dict[str, Any]) -> Toolpaths:
    """Run the engine once per zone of the density field (module docstring)."""
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
