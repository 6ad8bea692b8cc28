"""The one place the swarm engine imports numba: its ``njit``, and the on-disk cache of the kernels.

* ``cache=True``: the machine code is written to numba's cache (``__pycache__`` next to the
  sources, or ``NUMBA_CACHE_DIR``) the first time a kernel runs, so a machine compiles once (about a
  minute of CPU) and later processes load it (well under a second).
* ``error_model="numpy"``: division by zero gives inf/NaN as in numpy (the kernels test for them)
  instead of raising.
* no ``fastmath``: IEEE arithmetic, so results are deterministic and NaN tests work.

numba keys a cached function on its own source file only, but a cached caller holds the machine
code of every kernel it calls (numba links and optimises callees into the caller): editing
``kernel_geom.py`` would leave ``kernel_step.run_swarm`` running the old geometry code from the
cache.  Every kernel's cache entry is therefore stamped with all the sources compiled into the
kernels (:data:`SOURCES`), so editing any of them recompiles them all.

:func:`kernels_cached` tells (without compiling) whether the kernels are in the cache;
:func:`warm_up` compiles or loads them on a tiny layer (``scripts/setup.sh`` runs it once; a
process that forks workers calls it first so the workers inherit the compiled code).  When the
kernels have to be compiled, :func:`announce_compile` (called when :mod:`.kernel_step` is imported,
i.e. when the swarm engine is first used in a process) sends one line to the
``loadpath.engines.swarm`` logger, level WARNING, so a program that configures no logging (the CLI)
shows it on stderr.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from loadpath.errors import ToolMissingError

try:
    import numba
except ImportError as exc:  # pragma: no cover - numba is a hard dependency
    raise ToolMissingError(
        "the swarm engine needs numba (it compiles the per-step loop): pip install numba"
    ) from exc

__all__ = [
    "njit",
    "njit_inline",
    "objmode",
    "kernels_cached",
    "announce_compile",
    "warm_up",
    "COMPILE_SECONDS",
    "SOURCES",
]

log = logging.getLogger("loadpath.engines.swarm")

objmode = numba.objmode

_HERE = Path(__file__).resolve().parent
SOURCES = tuple(
    _HERE / f"{m}.py"
    for m in (
        "kernel_step",
        "kernel_geom",
        "kernel_qp",
        "kernel_widths",
        "kernel_ends",
        "kernel_raster",
        "chain",
    )
)
"""Files whose code or constants end up in the compiled kernels (``chain``: the box bounds; the
OSQP fallback of :mod:`.qp` runs in object mode, looked up at run time; ``kernel_widths``: the
finishing widths, compiled by :func:`warm_up` through the engine's last steps)."""

COMPILE_SECONDS = 60
"""About how long the first compile takes on one core of a CI machine (benchmarks/bench_swarm.py)."""

_DISPATCHERS: list[Any] = []


def _stamp() -> tuple:
    st = [os.stat(p) for p in SOURCES]
    return tuple((s.st_mtime, s.st_size) for s in st)


def _shared_stamp(disp: Any) -> Any:
    """Stamp ``disp``'s cache entries with every kernel source (see the module docstring)."""
    try:
        disp._cache._cache_file._source_stamp = _stamp()
    except (AttributeError, OSError):  # pragma: no cover - other numba internals: numba's own stamp
        pass
    _DISPATCHERS.append(disp)
    return disp


def njit(func: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``func`` in nopython mode, cached on disk, numpy error model."""
    return _shared_stamp(numba.njit(cache=True, error_model="numpy")(func))


def njit_inline(func: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``func`` into each of its compiled callers (numba IR inlining).

    For the stages of the step that run from one place: numba optimises a compiled function
    together with every compiled function it calls, so a stage compiled apart is optimised once on
    its own and again inside its caller; inlined, it is compiled only inside the caller.  Not for
    functions called from many places (each call site gets its own copy).
    """
    return _shared_stamp(numba.njit(cache=True, error_model="numpy", inline="always")(func))


def kernels_cached(disp: Any = None) -> bool:
    """Whether the swarm's loop (``kernel_step.run_swarm``, or ``disp``) is in numba's cache here.

    Reads the cache index only (no compile).  False also when the sources changed since.
    """
    if disp is None:
        from loadpath.engines.swarm import kernel_step

        disp = kernel_step.run_swarm
    if disp.signatures:  # compiled or loaded in this process already
        return True
    try:
        index = disp._cache._cache_file._load_index()
        magic = disp.targetctx.codegen().magic_tuple()
    except (AttributeError, OSError):  # pragma: no cover - other numba internals: assume cold
        return False
    return any(key[1] == magic for key in index)


_ANNOUNCED = False


def announce_compile(disp: Any = None) -> bool:
    """Log (once per process) that the kernels are about to be compiled, if they are not cached.

    Returns whether they are cached.
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


def warm_up() -> float:
    """Compile the kernels (or load them from the cache) by running the engine on a tiny layer.

    Logs one line first when they are not in the cache.  Returns the seconds it took.
    """
    from loadpath.engines.swarm.engine import generate
    from loadpath.field import AnalyticField, kirsch_tensor
    from loadpath.toolpath import EngineInput
    from shapely.geometry import LineString, Point, box

    announce_compile()
    t0 = time.perf_counter()
    region = box(0, 0, 6, 3).difference(Point(3, 1.5).buffer(0.5))
    field = AnalyticField(lambda p: kirsch_tensor(p, (3, 1.5), 0.5, 1.0), region, scale=3.0)
    generate(
        EngineInput(region=region, field=field, pitch=0.4, load_entry=LineString([(6, 0), (6, 3)])), K=5.0
    )
    # the raster of a finite-element field has its own kernel (the tiny layer above is analytic)
    from loadpath.engines.swarm.raster import FieldRaster
    from loadpath.fea.field import FEStressField

    tri = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    FieldRaster(FEStressField(tri, np.ones((2, 6, 3)), scale=1.0), (0.0, 0.0, 1.0, 1.0), 0.25)
    return time.perf_counter() - t0
