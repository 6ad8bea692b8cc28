"""Compile (or load from numba's cache) the swarm's kernels before they are needed.

``scripts/setup.sh`` runs :func:`warm_up` once; a process that forks workers calls it first so the
workers inherit the compiled code.  :func:`kernels_cached` tells, without compiling, whether the
swarm's loop is in the cache.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["warm_up", "kernels_cached"]


def kernels_cached() -> bool:
    """Whether the swarm's loop (``kernel_step.run_swarm``) is in numba's cache here (no compile)."""
    from loadpath.engines.finish._numba import kernels_cached as cached
    from loadpath.engines.swarm import kernel_step

    return cached(kernel_step.run_swarm)


def warm_up() -> float:
    """Compile the kernels (or load them from the cache) by running the engine on a tiny layer.

    Logs one line first when they are not in the cache.  Returns the seconds it took.
    """
    from loadpath.engines.swarm import kernel_step
    from loadpath.engines.swarm._jit import announce_compile
    from loadpath.engines.swarm.engine import generate
    from loadpath.field import AnalyticField, kirsch_tensor
    from loadpath.toolpath import EngineInput
    from shapely.geometry import LineString, Point, box

    announce_compile(kernel_step.run_swarm)
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
