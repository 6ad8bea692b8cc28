"""Path engines: ``swarm`` (the swarm paper) and ``streamlines`` (the thesis).

Each engine module exposes ``generate(inp: EngineInput, **params) -> Toolpaths``.
:func:`generate` picks one by name, importing it only when used.
"""

from __future__ import annotations

import importlib
from typing import Any

from loadpath.errors import SettingsError
from loadpath.toolpath import EngineInput, Toolpaths

__all__ = ["ENGINES", "generate"]

ENGINES = {
    "swarm": "loadpath.engines.swarm",
    "streamlines": "loadpath.engines.streamlines",
}


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
    result: Toolpaths = module.generate(inp, **params)
    return result
