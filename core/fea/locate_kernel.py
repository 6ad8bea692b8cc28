"""The compiled loop of :meth:`loadpath.fea.locate.TriangleLocator.locate`: one point at a time.

The numpy query advances every point by one candidate triangle per round, gathering and
reallocating its arrays each round (21 rounds on the verdict's mesh of the shipped example); the
verdict's bead model locates about 8 million sample points per prediction that way, 1.4 s of its
2.5 s.  This loop takes each point through its grid cell's candidates in the same order with the
same arithmetic (no ``fastmath``: no fused multiply-adds), so it returns the same triangles and the
same barycentric coordinates bit for bit; it stops at a point's first hit.

Compiled with the engines' ``njit`` (:mod:`loadpath.engines.finish._numba`: numba's on-disk cache,
stamped with this file), and imported only for large queries (:data:`loadpath.fea.locate.COMPILED_FROM`
points): a run whose analyses and predictions all come from the cache never imports numba.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from loadpath.jit import jit_family

__all__ = ["locate_points", "find", "barycentric", "grid_arrays"]

_njit, njit_inline = jit_family((Path(__file__).resolve(),))


@njit_inline
def barycentric(x, y, t, x0, y0, m00, m01, m10, m11):  # noqa: N803
    """Barycentric coordinates ``(l0, l1, l2)`` of point ``(x, y)`` in triangle ``t`` (the locator's
    corner ``x0, y0`` and inverse edge matrix ``m``).  Compiled into each caller: :func:`find`, and
    :mod:`loadpath.stiffness.sample_kernel`'s test of the element of the point before."""
    q0 = x - x0[t]
    q1 = y - y0[t]
    l1 = m00[t] * q0 + m01[t] * q1
    l2 = m10[t] * q0 + m11[t] * q1
    return 1.0 - l1 - l2, l1, l2


@njit_inline
def find(x, y, ox, oy, step, nx, ny, start, cand, x0, y0, m00, m01, m10, m11, eps, bary):  # noqa: N803
    """The triangle holding point ``(x, y)`` (-1: none), its barycentric coordinates into ``bary`` (3,).

    The arguments after the point are the locator's grid and triangles as :func:`locate_points`
    passes them.  Compiled into each caller (also :mod:`loadpath.stiffness.sample_kernel`'s).
    """
    fx = (x - ox) / step
    fy = (y - oy) / step
    if not (fx >= -eps and fy >= -eps and fx <= nx + eps and fy <= ny + eps):  # NaN: outside
        return -1
    ix = min(int(max(fx, 0.0)), nx - 1)
    iy = min(int(max(fy, 0.0)), ny - 1)
    c = ix * ny + iy
    for k in range(start[c], start[c + 1]):
        t = cand[k]
        l0, l1, l2 = barycentric(x, y, t, x0, y0, m00, m01, m10, m11)
        if l0 >= -eps and l1 >= -eps and l2 >= -eps:
            bary[0] = l0
            bary[1] = l1
            bary[2] = l2
            return t
    return -1


@_njit
def _locate(px, py, ox, oy, step, nx, ny, start, cand, x0, y0, m00, m01, m10, m11, eps, tri, bary):  # noqa: N803
    for i in range(px.shape[0]):
        t = find(px[i], py[i], ox, oy, step, nx, ny, start, cand, x0, y0, m00, m01, m10, m11, eps, bary[i])
        if t >= 0:
            tri[i] = t


def grid_arrays(locator) -> tuple:  # type: ignore[no-untyped-def]
    """The locator's grid and triangles as :func:`find` takes them (after the point, before ``eps``)."""
    g = locator.grid
    col = np.ascontiguousarray
    return (
        float(g.origin[0]), float(g.origin[1]), float(g.step), int(g.shape[0]), int(g.shape[1]),
        col(g.start, dtype=np.int64), col(g.tri, dtype=np.int64),
        col(locator.p0[:, 0]), col(locator.p0[:, 1]), col(locator.inv[:, 0, 0]), col(locator.inv[:, 0, 1]),
        col(locator.inv[:, 1, 0]), col(locator.inv[:, 1, 1]),
    )


def locate_points(locator, pts: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`TriangleLocator.locate` of ``pts`` ((p, 2) float, mm) in the compiled loop.

    Returns
    -------
    tri : (p,) int64
        Triangle index, -1 where no triangle holds the point.
    bary : (p, 3) float
        Barycentric coordinates in that triangle (0 where none).
    """
    p = len(pts)
    tri = np.full(p, -1, dtype=np.int64)
    bary = np.zeros((p, 3))
    col = np.ascontiguousarray
    _locate(col(pts[:, 0]), col(pts[:, 1]), *grid_arrays(locator), float(eps), tri, bary)
    return tri, bary
