"""Compiled kernel of the field raster (:mod:`.raster`): a finite-element field scanned onto the grid.

:class:`.raster.FieldRaster` needs the stress tensor at every node of a grid over the layer (a
hundred thousand nodes on the open-hole specimen).  Asking the field for them point by point means
locating every node in the mesh.  :func:`scan_triangles` turns it round: each triangle visits the
grid nodes in its bounding box, keeps those inside it (barycentric coordinates within ``eps``, as
:meth:`.fea.locate.TriangleLocator.locate` accepts them) and evaluates its interpolant there.  A
node on an edge shared by two triangles takes the first triangle's value, as the locator would
take the first triangle it tests (both are the same field up to the jump of the recovered stress
across that edge).
"""

from __future__ import annotations

import numpy as np
from loadpath.engines.swarm._jit import njit

__all__ = ["scan_triangles"]


@njit
def scan_triangles(
    corners: np.ndarray, coef: np.ndarray, origin: np.ndarray, cell: float, nx: int, ny: int, eps: float
) -> np.ndarray:
    """Tensor of a triangle field at the nodes of a grid (NaN at nodes no triangle holds).

    Parameters
    ----------
    corners : (m, 3, 2) float, mm
        Triangle corners.
    coef : (m, k, 3) float, MPa
        Each triangle's interpolant as a polynomial in its barycentric ``(l1, l2)``: monomials
        ``[1, l1, l2]`` (k = 3) or ``[1, l1, l2, l1², l1 l2, l2²]`` (k = 6), per tensor component.
    origin : (2,) float, mm
    cell : float, mm
    nx, ny : int
        Node ``(i, j)`` at ``origin + (i, j) cell``, flat index ``i ny + j``.
    eps : float
        Barycentric tolerance.

    Returns
    -------
    (nx ny, 3) float, MPa
    """
    out = np.full((nx * ny, 3), np.nan)
    k = coef.shape[1]
    for t in range(corners.shape[0]):
        x0, y0 = corners[t, 0, 0], corners[t, 0, 1]
        e1x, e1y = corners[t, 1, 0] - x0, corners[t, 1, 1] - y0
        e2x, e2y = corners[t, 2, 0] - x0, corners[t, 2, 1] - y0
        det = e1x * e2y - e1y * e2x
        scale = max(max(abs(e1x), abs(e1y)), max(abs(e2x), abs(e2y))) ** 2
        if not abs(det) > 1e-12 * max(scale, 1e-300):
            continue  # degenerate: the locator ignores it too
        a00, a01, a10, a11 = e2y / det, -e2x / det, -e1y / det, e1x / det
        lo_x = min(x0, x0 + e1x, x0 + e2x)
        hi_x = max(x0, x0 + e1x, x0 + e2x)
        lo_y = min(y0, y0 + e1y, y0 + e2y)
        hi_y = max(y0, y0 + e1y, y0 + e2y)
        i0 = max(int(np.ceil((lo_x - origin[0]) / cell - 1e-9)), 0)
        i1 = min(int(np.floor((hi_x - origin[0]) / cell + 1e-9)), nx - 1)
        j0 = max(int(np.ceil((lo_y - origin[1]) / cell - 1e-9)), 0)
        j1 = min(int(np.floor((hi_y - origin[1]) / cell + 1e-9)), ny - 1)
        for i in range(i0, i1 + 1):
            qx = origin[0] + cell * i - x0
            for j in range(j0, j1 + 1):
                n = i * ny + j
                if not np.isnan(out[n, 0]):
                    continue
                qy = origin[1] + cell * j - y0
                l1 = a00 * qx + a01 * qy
                l2 = a10 * qx + a11 * qy
                if l1 < -eps or l2 < -eps or 1.0 - l1 - l2 < -eps:
                    continue
                for c in range(3):
                    v = coef[t, 0, c] + coef[t, 1, c] * l1 + coef[t, 2, c] * l2
                    if k == 6:
                        v += coef[t, 3, c] * l1 * l1 + coef[t, 4, c] * l1 * l2 + coef[t, 5, c] * l2 * l2
                    out[n, c] = v
    return out
