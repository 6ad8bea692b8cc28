"""The swarm's compiled-kernel plumbing: ``njit`` stamped with its sources, and the compile notice.

The swarm's step (:mod:`.kernel_step`) calls the shared geometry, width and end kernels of
:mod:`loadpath.engines.finish`, whose machine code numba compiles into it; so its kernels are
stamped with those sources and its own (:data:`SOURCES`, see
:mod:`loadpath.engines.finish._numba`): editing any of them recompiles the swarm's kernels.

When the kernels have to be compiled, :func:`announce_compile` (called when :mod:`.kernel_step` is
imported, i.e. when the swarm engine is first used in a process) sends one line to the
``loadpath.engines.swarm`` logger, level WARNING, so a program that configures no logging (the CLI)
shows it on stderr.  :func:`loadpath.engines.swarm.warmup.warm_up` compiles or loads them.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from loadpath.engines.finish import _numba as _shared
from loadpath.engines.finish._numba import kernels_cached, objmode

__all__ = ["njit", "njit_inline", "objmode", "announce_compile", "COMPILE_SECONDS", "SOURCES"]

log = logging.getLogger("loadpath.engines.swarm")

_HERE = Path(__file__).resolve().parent
SOURCES = _shared.SOURCES + tuple(
    _HERE / f"{m}.py" for m in ("kernel_step", "kernel_qp", "kernel_raster", "chain")
)
"""Files whose code or constants end up in the swarm's compiled kernels (``chain``: the box bounds;
the OSQP fallback of :mod:`.qp` runs in object mode, looked up at run time; the shared kernels of
:mod:`loadpath.engines.finish`: compiled into the step)."""

COMPILE_SECONDS = 60
"""About how long the first compile takes on one core of a CI machine (benchmarks/bench_swarm.py)."""

njit, njit_inline = _shared.jit_family(SOURCES)

_ANNOUNCED = False


def announce_compile(disp: Any) -> bool:
    """Log (once per process) that the kernels are about to be compiled, if ``disp`` is not cached.

    Returns whether it is cached.
    """
    global _ANNOUNCED
    cached = kernels_cached(disp)
    if not cached and not _ANNOUNCED:
        _ANNOUNCED = True
        log.warning(
            "loadpath: compiling the swarm engine (first run on this machine, about %d s; cached afterwards)",
            COMPILE_SECONDS,
        )
    return cached
