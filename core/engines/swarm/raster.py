"""The stress field on a raster at the step scale, so a swarm step samples it with array lookups.

A swarm step asks for the field at every agent (about a hundred points), hundreds of times per
layer.  Asking the :class:`~loadpath.field.StressField` each time costs its fixed overhead per call
(point location in the finite-element mesh: about 0.5 ms for 90 points), more than the rest of the
step.  :class:`FieldRaster` asks once, for the nodes of a grid of ``cell`` (the engine's default:
half a pitch) over the region, and then interpolates the **tensor** bilinearly (never direction
vectors, which have no sign) and decomposes it in closed form, as :meth:`StressField.sample` does.
Nodes outside the part take the tensor of the nearest node inside, so points near the boundary
interpolate from the part only.

The lookup is the compiled kernel :func:`.kernel_geom.raster_sample`, which the swarm's step
calls directly on :attr:`FieldRaster.data`.

Rasters are cached per field (weakly) and reused for any region inside the rastered box with the
same cell: a 2D analysis gives every layer of a body the same field, so only its first layer pays.
"""

from __future__ import annotations

import weakref

import numpy as np
from loadpath._typing import Bools, Floats, Points2
from loadpath.engines.finish import kernel_geom as kg
from loadpath.engines.swarm import kernel_raster as kr
from loadpath.fea.field import FEStressField
from loadpath.field import StressField
from loadpath.tolerances import TOL
from scipy.ndimage import distance_transform_edt

__all__ = ["FieldRaster", "raster_for", "clear_cache"]

_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_PRINCIPAL = {"tensile": 0, "compressive": 1, "max_abs": 2, "min_abs": 3}


class FieldRaster:
    """Tensor raster of a stress field over a box.

    Parameters
    ----------
    field : StressField
    bounds : (xmin, ymin, xmax, ymax), mm
    cell : float, mm
        Node spacing.
    """

    def __init__(self, field: StressField, bounds: tuple[float, float, float, float], cell: float) -> None:
        x0, y0, x1, y1 = (float(b) for b in bounds)
        self.cell = float(cell)
        self.origin = np.array([x0 - self.cell, y0 - self.cell])
        self.nx = int(np.ceil((x1 - x0) / self.cell)) + 3
        self.ny = int(np.ceil((y1 - y0) / self.cell)) + 3
        self.bounds = (x0, y0, x1, y1)
        if isinstance(field, FEStressField):
            # a finite-element field is scanned triangle by triangle onto the nodes (compiled): the
            # same values as locating every node in the mesh, 68 -> 20 ms on the specimen's layer
            t = kr.scan_triangles(
                field.corners, field.coefficients, self.origin, self.cell, self.nx, self.ny, 1e-9
            ).reshape(self.nx, self.ny, 3)
        else:
            gx = self.origin[0] + self.cell * np.arange(self.nx)
            gy = self.origin[1] + self.cell * np.arange(self.ny)
            pts = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
            t = np.asarray(field.tensor(pts), dtype=float).reshape(self.nx, self.ny, 3)
        ok = np.all(np.isfinite(t), axis=2)
        if not np.any(ok):
            t = np.zeros_like(t)
        elif not np.all(ok):
            i, j = distance_transform_edt(~ok, return_distances=False, return_indices=True)
            t = t[i, j]
        self.tensor = np.ascontiguousarray(t.reshape(-1, 3))
        self._imax = np.array([self.nx - 2, self.ny - 2], dtype=float)
        self.principal = field.principal
        self.scale = field.scale if field.scale > 0 else 1.0
        self._aniso_min = TOL.anisotropy_rel * self.scale
        self.data = kg.RasterData(
            tensor=self.tensor,
            origin=self.origin,
            cell=self.cell,
            ny=int(self.ny),
            imax=self._imax,
            principal=_PRINCIPAL[self.principal],
            scale=float(self.scale),
            aniso_min=float(self._aniso_min),
        )

    def covers(self, bounds: tuple[float, float, float, float], cell: float) -> bool:
        """Whether this raster serves a region with these bounds at this cell size."""
        x0, y0, x1, y1 = self.bounds
        return (
            abs(cell - self.cell) <= 1e-12 * cell
            and bounds[0] >= x0
            and bounds[1] >= y0
            and bounds[2] <= x1
            and bounds[3] <= y1
        )

    def interpolate(self, points: Points2) -> np.ndarray:
        """Bilinearly interpolated tensor ``[sxx, syy, sxy]`` at points, (n, 3) MPa."""
        f = (np.asarray(points, dtype=float) - self.origin) / self.cell
        i = np.minimum(np.maximum(np.floor(f), 0.0), self._imax)
        w = np.minimum(np.maximum(f - i, 0.0), 1.0)
        k = (i[:, 0] * self.ny + i[:, 1]).astype(np.intp)
        T = self.tensor
        wx, wy = w[:, 0:1], w[:, 1:2]
        a = T[k] + wy * (T[k + 1] - T[k])
        b = T[k + self.ny] + wy * (T[k + self.ny + 1] - T[k + self.ny])
        return a + wx * (b - a)

    def sample(self, points: Points2) -> tuple[Points2, Floats, Bools]:
        """Followed principal direction, virtual mass and validity at points.

        Parameters
        ----------
        points : (n, 2) float, mm

        Returns
        -------
        direction : (n, 2) float
            Unit vector (sign arbitrary).
        mass : (n,) float
            ``|sigma| / scale`` clipped to [0, 1] (paper footnote 1).
        valid : (n,) bool
            The direction is defined (anisotropy above ``TOL.anisotropy_rel * scale``).
        """
        p = np.ascontiguousarray(np.asarray(points, dtype=float).reshape(-1, 2))
        return kg.raster_sample(self.data, p)


def raster_for(field: StressField, bounds: tuple[float, float, float, float], cell: float) -> FieldRaster:
    """Return a raster of ``field`` covering ``bounds`` at ``cell``, from the cache if one serves."""
    try:
        cached = _CACHE.setdefault(field, [])
    except TypeError:  # a field that cannot be weakly referenced: no cache
        return FieldRaster(field, bounds, cell)
    for r in cached:
        if r.covers(bounds, cell) and r.principal == field.principal:
            return r
    r = FieldRaster(field, bounds, cell)
    cached.append(r)
    return r


def clear_cache() -> None:
    """Forget all cached rasters (benchmarks time a cold start with it)."""
    _CACHE.clear()
