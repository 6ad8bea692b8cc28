"""The direction field the streamlines follow: sign-free, cached on a grid, with a validity mask.

Sign-consistent interpolation (digest §1.2, settled here)
    The thesis interpolates the components ``u, v`` of the sign-less principal direction
    separately (MATLAB ``scatteredInterpolant``).  Where neighbouring nodes carry opposite signs
    the interpolant cancels to a spurious ``|v| ~ 0`` that the thesis would read as "boundary".
    Here each grid node stores the doubled-angle vector ``q = (cos 2t, sin 2t)`` of
    ``field.sample``'s direction, which is the same for ``d`` and ``-d``; ``q`` is interpolated
    bilinearly and the direction is recovered as ``t = atan2(q_y, q_x) / 2``.  The sign of each
    step is then chosen against the previous step (:mod:`.integrate`), which is the thesis's own
    rule (Sec. 4.1.1, Fig. 4.3b).  Only ``field.sample`` is used, so fields whose ``direction``
    flips sign from point to point are handled by construction.

Degenerate points (digest §1.2, settled here)
    Where the field says the direction is undefined (``valid`` false: isotropic stress, no stress)
    the node's ``q`` is 0.  The interpolated ``|q|`` is then short near such nodes, and also where
    the followed direction jumps (``max_abs`` turns by 90 degrees across a neutral axis, so ``q``
    and ``-q`` meet) or spreads by more than about +-36 degrees within one grid cell (the
    neighbourhood of a degenerate point).  ``|q| < Q_MIN`` marks the direction undefined and the
    streamline stops there instead of wandering through a singularity.

Why a grid
    ``field.sample`` may be a finite-element lookup; tracing thousands of streamlines needs millions
    of direction queries.  The field is sampled once on a grid (about ``grid_spacing`` mm, at most
    ~2e5 nodes) and queries are a bilinear gather.  Nodes outside the part take the value of the
    nearest inside node, so cells that straddle the boundary interpolate inside values only; the
    exact inside test is the region's (:meth:`DirectionGrid.inside`).
"""

from __future__ import annotations

import numpy as np
import shapely
from loadpath._typing import Bools, Points2, Region, Vectors2
from loadpath.field import StressField
from scipy import ndimage

__all__ = ["Q_MIN", "DirectionGrid"]

Q_MIN = 0.3
"""Shortest interpolated doubled-angle vector that still defines a direction (see module doc)."""

_MAX_NODES = 200_000


class DirectionGrid:
    """Principal directions of a field cached on a regular grid over a region.

    Parameters
    ----------
    field : StressField
        Already set to the principal stress to follow.
    region : Polygon or MultiPolygon, mm
    spacing : float, mm
        Requested node spacing; enlarged if the grid would exceed ~2e5 nodes.

    Attributes
    ----------
    field : StressField
        The sampled field.
    spacing : float, mm
    mass_max : float
        Largest virtual mass on the grid (for diagnostics).
    """

    def __init__(self, field: StressField, region: Region, spacing: float) -> None:
        x0, y0, x1, y1 = region.bounds
        area = max((x1 - x0) * (y1 - y0), 1e-12)
        g = max(float(spacing), float(np.sqrt(area / _MAX_NODES)))
        self.spacing = g
        self.region = region
        self.field = field
        shapely.prepare(region)
        self.x0 = x0 - 2 * g
        self.y0 = y0 - 2 * g
        nx = int(np.ceil((x1 - x0) / g)) + 5
        ny = int(np.ceil((y1 - y0) / g)) + 5
        self.nx, self.ny = nx, ny
        gx = self.x0 + g * np.arange(nx)
        gy = self.y0 + g * np.arange(ny)
        px, py = np.meshgrid(gx, gy)
        nodes = np.stack([px.ravel(), py.ravel()], axis=1)
        smp = field.sample(nodes)
        d = np.where(np.isfinite(smp.direction), smp.direction, 0.0)
        c2 = d[:, 0] ** 2 - d[:, 1] ** 2  # cos 2t of a unit vector
        s2 = 2.0 * d[:, 0] * d[:, 1]  # sin 2t
        ok = smp.valid
        q = np.stack([np.where(ok, c2, 0.0), np.where(ok, s2, 0.0)], axis=0).reshape(2, ny, nx)
        inside = smp.inside.reshape(ny, nx)
        if np.any(inside) and not np.all(inside):
            # outside nodes copy the nearest inside node (no blending towards 0 at the boundary)
            _, (iy, ix) = ndimage.distance_transform_edt(~inside, return_indices=True)
            q = q[:, iy, ix]
        self.q = q
        self._qc = (q[0] + 1j * q[1]).ravel()  # one complex gather per corner
        self._inv = 1.0 / g
        self.mass_max = float(np.max(smp.mass)) if len(smp.mass) else 0.0

    def __call__(self, points: Points2) -> tuple[Vectors2, Bools]:
        """Return the unit principal direction (sign arbitrary) at points and whether it is defined.

        Parameters
        ----------
        points : (n, 2) float, mm

        Returns
        -------
        direction : (n, 2) float
        ok : (n,) bool
            False where ``|q| < Q_MIN`` (degenerate point, jump of the followed stress).
        """
        p = np.asarray(points, dtype=float)
        fx = (p[:, 0] - self.x0) * self._inv
        fy = (p[:, 1] - self.y0) * self._inv
        ix = np.minimum(np.maximum(fx.astype(np.int64), 0), self.nx - 2)
        iy = np.minimum(np.maximum(fy.astype(np.int64), 0), self.ny - 2)
        tx = np.minimum(np.maximum(fx - ix, 0.0), 1.0)
        ty = np.minimum(np.maximum(fy - iy, 0.0), 1.0)
        flat = iy * self.nx + ix
        qc = self._qc
        nx = self.nx
        lo = qc[flat] + (qc[flat + 1] - qc[flat]) * tx
        hi = qc[flat + nx] + (qc[flat + nx + 1] - qc[flat + nx]) * tx
        q = lo + (hi - lo) * ty
        mag = np.abs(q)
        ok = mag >= Q_MIN
        # half-angle of q without trigonometry: (cos t, sin t) ~ (|q| + Re q, Im q), t in (-90, 90]
        h = q + mag
        hn = np.abs(h)
        bad = hn <= 1e-12 * np.maximum(mag, 1e-300)  # q points along -x: t = 90 degrees
        if np.any(bad):
            h = np.where(bad, 1j, h)
            hn = np.where(bad, 1.0, hn)
        h = h / hn
        return np.stack([h.real, h.imag], axis=1), ok

    def dominant(self) -> np.ndarray:
        """Return the dominant direction (unit vector): the doubled-angle mean over the region's nodes."""
        g = self.spacing
        gx = self.x0 + g * np.arange(self.nx)
        gy = self.y0 + g * np.arange(self.ny)
        px, py = np.meshgrid(gx, gy)
        ins = shapely.contains_xy(self.region, px, py).ravel()
        qm = self._qc[ins].mean() if np.any(ins) else 1.0 + 0.0j
        if abs(qm) == 0:
            qm = 1.0 + 0.0j
        t = 0.5 * np.angle(qm)
        return np.array([np.cos(t), np.sin(t)])

    def undefined_zone(self) -> Region:
        """Where the direction is undefined, as grid cells inside the region (possibly empty).

        Streamlines end at these zones (jump lines of ``max_abs``, degenerate points) as they end at
        the boundary, so the default mode seeds around them as it seeds along the boundary.
        """
        g = self.spacing
        xs = self.x0 + g * (np.arange(self.nx - 1) + 0.5)
        ys = self.y0 + g * (np.arange(self.ny - 1) + 0.5)
        cx, cy = np.meshgrid(xs, ys)
        pts = np.stack([cx.ravel(), cy.ravel()], axis=1)
        _, ok = self(pts)
        bad = ~ok
        if np.any(bad):
            bad[bad] = self.inside(pts[bad])
        if not np.any(bad):
            return shapely.Polygon()
        c = pts[bad]
        cells = shapely.box(c[:, 0] - 0.5 * g, c[:, 1] - 0.5 * g, c[:, 0] + 0.5 * g, c[:, 1] + 0.5 * g)
        return shapely.union_all(cells).intersection(self.region)

    def inside(self, points: Points2) -> Bools:
        """Exact test: points inside the region (boundary excluded), (n,) bool."""
        p = np.asarray(points, dtype=float)
        return shapely.contains_xy(self.region, p[:, 0], p[:, 1])
