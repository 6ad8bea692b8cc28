"""numba for every compiled kernel of loadpath, and the on-disk cache of the kernels.

Used by the engines (:mod:`loadpath.engines.finish._numba` and ``loadpath.engines.swarm._jit``), the
FEA's point location of large queries (:mod:`loadpath.fea.locate_kernel`) and the stiffness model's
bead sampling (:mod:`loadpath.stiffness.sample_kernel`); it sits at the bottom of the import stack so
each of them can take its ``njit`` from here.

* ``cache=True``: the machine code is written to numba's cache (``__pycache__`` next to the
  sources, or ``NUMBA_CACHE_DIR``) the first time a kernel runs, so a machine compiles once (about a
  minute of CPU) and later processes load it (well under a second).
* ``error_model="numpy"``: division by zero gives inf/NaN as in numpy (the kernels test for them)
  instead of raising.
* no ``fastmath``: IEEE arithmetic, so results are deterministic and NaN tests work.

numba keys a cached function on its own source file only, but a cached caller holds the machine
code of every kernel it calls (numba links and optimises callees into the caller): editing
``kernel_geom.py`` would leave the swarm's ``kernel_step.run_swarm`` running the old geometry code
from the cache.  Every kernel's cache entry is therefore stamped with all the sources that can be
compiled into it: :func:`jit_family` gives an ``njit``/``njit_inline`` pair stamped with a list of
sources (:data:`FAMILIES` keeps which), and a family whose kernels call another's lists that
family's sources too, so editing a shared kernel recompiles its callers.

:func:`kernels_cached` tells (without compiling) whether a kernel is in the cache.
"""


from __future__ import annotations

import os
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

from loadpath.errors import ToolMissingError

try:
    import numba
except ImportError as exc:  # pragma: no cover - numba is a hard dependency
    raise ToolMissingError(
        "loadpath needs numba (it compiles the swarm's step, the finishing kernels, the point location of "
        "large queries and the verdict's bead sampling): pip install numba"
    ) from exc

__all__ = ["objmode", "jit_family", "kernels_cached", "FAMILIES"]

objmode = numba.objmode

FAMILIES: list[tuple[Any, tuple[Path, ...]]] = []
"""Every kernel made by a :func:`jit_family` pair, with the sources its cache entries are stamped with."""


def _stamp(sources: tuple[Path, ...]) -> tuple:
    st = [os.stat(p) for p in sources]
    return tuple((s.st_mtime, s.st_size) for s in st)


def _stale_safe(load_index: Callable[[], Any]) -> Callable[[], Any]:
    """``load_index`` reading an index it cannot unpickle as an empty one (a stale cache).

    An index pickles the argument types of each compiled signature by module path; one written
    before a kernel module moved names a module that no longer exists, and numba would raise
    ``ModuleNotFoundError`` instead of compiling again.  Empty, the kernel compiles and the index
    is rewritten.
    """

    def load() -> Any:
        try:
            return load_index()
        except (ImportError, AttributeError, EOFError, pickle.UnpicklingError):
            return {}

    return load


def _shared_stamp(disp: Any, sources: tuple[Path, ...]) -> Any:
    """Stamp ``disp``'s cache entries with every source in ``sources`` (see the module docstring)."""
    try:
        cache_file = disp._cache._cache_file
        cache_file._source_stamp = _stamp(sources)
        cache_file._load_index = _stale_safe(cache_file._load_index)
    except (AttributeError, OSError):  # pragma: no cover - other numba internals: numba's own stamp
        pass
    FAMILIES.append((disp, tuple(sources)))
    return disp


_Jit = Callable[[Callable[..., Any]], Callable[..., Any]]


def jit_family(sources: tuple[Path, ...]) -> tuple[_Jit, _Jit]:
    """``(njit, njit_inline)`` whose kernels' cache entries are stamped with ``sources``.

    ``njit`` compiles in nopython mode, cached on disk, numpy error model.  ``njit_inline`` compiles
    a function into each of its compiled callers (numba IR inlining): for the stages of a step that
    run from one place, since numba optimises a compiled function together with every compiled
    function it calls, so a stage compiled apart is optimised once on its own and again inside its
    caller; inlined, it is compiled only inside the caller.  Not for functions called from many
    places (each call site gets its own copy).
    """

    def njit(func: Callable[..., Any]) -> Callable[..., Any]:
        return _shared_stamp(numba.njit(cache=True, error_model="numpy")(func), sources)

    def njit_inline(func: Callable[..., Any]) -> Callable[..., Any]:
        return _shared_stamp(numba.njit(cache=True, error_model="numpy", inline="always")(func), sources)

    return njit, njit_inline



def kernels_cached(disp: Any) -> bool:
    """Whether the compiled function ``disp`` is in numba's cache here.

    Reads the cache index only (no compile).  False also when the sources changed since.
    """
    if disp.signatures:  # compiled or loaded in this process already
        return True
    try:
        index = disp._cache._cache_file._load_index()
        magic = disp.targetctx.codegen().magic_tuple()
    except (AttributeError, OSError):  # pragma: no cover - other numba internals: assume cold
        return False
    return any(key[1] == magic for key in index)
