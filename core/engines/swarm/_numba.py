"""The one place the swarm engine imports numba: its ``njit`` with the settings every kernel shares.

* ``cache=True``: the machine code is written next to the sources (``__pycache__``) the first time
  a kernel runs, so a machine compiles once; later processes load it.
* ``error_model="numpy"``: division by zero gives inf/NaN as in numpy (the kernels test for them)
  instead of raising.
* no ``fastmath``: IEEE arithmetic, so results are deterministic and NaN tests work.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from loadpath.errors import ToolMissingError

try:
    import numba
except ImportError as exc:  # pragma: no cover - numba is a hard dependency
    raise ToolMissingError(
        "the swarm engine needs numba (it compiles the per-step loop): pip install numba"
    ) from exc

__all__ = ["njit", "njit_inline", "objmode"]

objmode = numba.objmode


def njit(func: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``func`` in nopython mode, cached on disk, numpy error model."""
    return numba.njit(cache=True, error_model="numpy")(func)


def njit_inline(func: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``func`` into its callers (numba IR inlining).

    The stages of the swarm's step are inlined into the loop: numba emits and optimises the
    machine code of every separately compiled callee again inside each caller, so a deep tree of
    compiled functions costs several times the compile time of one flat function.
    """
    return numba.njit(cache=True, error_model="numpy", inline="always")(func)
