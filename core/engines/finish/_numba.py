"""The ``njit`` of this package's kernels: :func:`loadpath.jit.jit_family` stamped with :data:`SOURCES`.

The finishing kernels (widths, ends) and the geometry kernels they and the swarm's step call are
compiled with this pair; an engine whose kernels call them makes its own pair with :data:`SOURCES`
plus its files (``loadpath.engines.swarm._jit``), so editing a shared kernel recompiles that
engine's kernels too (:mod:`loadpath.jit` says why).  Nothing here imports an engine: the warm-up
that runs an engine on a tiny layer belongs to the engine (``loadpath.engines.swarm.warmup``).
"""

from __future__ import annotations

from pathlib import Path

from loadpath.jit import jit_family, kernels_cached, objmode

__all__ = ["njit", "njit_inline", "objmode", "jit_family", "kernels_cached", "SOURCES"]

_HERE = Path(__file__).resolve().parent

SOURCES = tuple(_HERE / f"{m}.py" for m in ("kernel_geom", "kernel_widths", "kernel_ends"))
"""Files whose code ends up in this package's compiled kernels (the finishing widths and ends, and
the geometry kernels they and the swarm's step call)."""

njit, njit_inline = jit_family(SOURCES)
