"""Whether this process runs the splice's compiled loops (:mod:`loadpath.splice.kernels`).

A splice of :data:`COMPILED_FROM` path vertices or more loads them (:func:`load`) before its workers
fork, and from then on :func:`kernel` hands them to :func:`loadpath.splice.plan.simplify_mask` and
:func:`loadpath.splice.beadruns.runs_of_widths`, which otherwise run their numpy and Python passes.
Both ways give the same results bit for bit; a small file's run never imports numba for them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["COMPILED_FROM", "load", "kernel"]

COMPILED_FROM = 2_000_000
"""Vertices in a splice's paths from which it runs compiled.  Loading numba and the kernels takes
about 0.45 s, before the splice's workers fork.  The numpy RDP pass takes about 0.27 us a vertex
and the compiled loop a sixth of that, two passes a vertex (bead runs: position and extrusion, then
position), so on two workers the load pays from about 2 million vertices.  The 1000-layer
specimen's paths have 7.5 million: its splice's RDP passes 4.04 -> 0.88 s (one process)."""

_LOADED: dict[str, Callable[..., Any]] = {}


def load() -> None:
    """Load the compiled loops into this process (and the processes it forks from now on)."""
    if _LOADED:
        return
    import numpy as np
    from loadpath.splice.kernels import rdp_keep, run_index

    one = np.zeros(3)
    rdp_keep(one, one, one, np.zeros(1, np.int64), np.full(1, 3, np.int64), 1.0, 1.0, np.zeros(3, bool))
    run_index(one, np.zeros(3, bool), np.zeros(3, bool), 1.1)
    _LOADED.update(rdp=rdp_keep, runs=run_index)


def kernel(name: str) -> Callable[..., Any] | None:
    """The compiled loop ``name`` (``"rdp"``, ``"runs"``) when :func:`load` has run, else None."""
    return _LOADED.get(name)
