"""Path engines: ``swarm`` (the swarm paper), ``streamlines`` (the thesis) and ``levelset`` (the
thesis's Ch. 3 level sets), and what they share.

Each engine module exposes ``generate(inp: EngineInput, **options) -> Toolpaths``; the registry
(:mod:`.registry`) names them and tells the pipeline how to run each.  :func:`generate` picks one by
name, importing it only when used.  :mod:`.finish` holds the finishing stages both engines run
(path ends, bead widths) and the compiled kernels under them; no engine imports another.

A spatially varying pitch (``inp.density``, :mod:`loadpath.density`) is laid by the level-set engine
itself (its line density follows the field); for the others it is laid by zones: the region is
split where the density field's pitch, rounded to a few levels, changes (:mod:`loadpath.engines.zones`),
and the engine fills each zone at its own pitch; the paths of all zones come back as one layer.
Inside a zone both engines' spacing terms use its pitch (the swarm's QP box and spacing, the
streamlines' seeding distance and minimum spacing), so ``l(x)`` is piecewise constant.
"""

from __future__ import annotations

from loadpath.engines.registry import (
    DEFAULT,
    NAMES,
    SOLID_FIRST,
    SPARSE_CHOICES,
    SPARSE_DEFAULT,
    Engine,
    Machine,
    first_on_solid,
    for_sparse,
    generate,
    get,
    register,
    unregister,
    warm_up,
)

__all__ = [
    "NAMES",
    "DEFAULT",
    "SPARSE_CHOICES",
    "SPARSE_DEFAULT",
    "SOLID_FIRST",
    "Engine",
    "Machine",
    "first_on_solid",
    "for_sparse",
    "generate",
    "get",
    "register",
    "unregister",
    "warm_up",
]
