"""Analytic stress fields and helpers for the streamline engine tests.

Every field is a closed form (``AnalyticField``), so the tests do not depend on the FEA; the
regions are small so that each test runs in well under a second in the default mode.
"""

from __future__ import annotations

import numpy as np
import shapely
from loadpath.engines.streamlines._lines import Lines, segment_distance
from loadpath.field import AnalyticField, FieldSample, StressField, kirsch_tensor
from scipy.spatial import cKDTree
from shapely.geometry import Point, box

PITCH = 0.45


def uniform(angle_deg: float = 0.0, s: float = 10.0):
    a = np.deg2rad(angle_deg)
    c, si = np.cos(a), np.sin(a)
    return lambda p: np.tile([s * c * c, s * si * si, s * c * si], (len(p), 1))


def shear(tau: float = 10.0):
    """Pure shear: principal directions at +-45 degrees everywhere."""
    return lambda p: np.tile([0.0, 0.0, tau], (len(p), 1))


def bending(height: float, length: float, force: float = 1.0):
    """Cantilever (clamped at x = 0, tip load at x = length): sxx = M y / I, sxy parabolic."""
    c = 0.5 * height
    inertia = height**3 / 12.0

    def f(p):
        x, y = p[:, 0], p[:, 1] - c
        sxx = -force * (length - x) * y / inertia
        sxy = -force / (2 * inertia) * (c * c - y * y)
        return np.stack([sxx, np.zeros_like(sxx), sxy], axis=1)

    return f


def radial(center, s: float = 10.0):
    """Radial tension about a point (a degenerate point at the centre)."""
    cx, cy = center

    def f(p):
        d = p - np.array([cx, cy])
        r2 = np.maximum(np.sum(d * d, axis=1), 1e-12)
        return s * np.stack([d[:, 0] ** 2 / r2, d[:, 1] ** 2 / r2, d[:, 0] * d[:, 1] / r2], axis=1)

    return f


def vertical_flipping(eps: float = 1e-3, s: float = 10.0, period: float = 0.37):
    """Tension along y with a tiny shear whose sign alternates in x.

    The principal direction is vertical everywhere, but ``principal_stresses`` returns it as
    ``(~0, +1)`` or ``(~0, -1)`` depending on the sign of the shear (the atan2 branch cut), so the
    direction vectors of neighbouring points have opposite signs: the thesis's component-wise
    interpolation would cancel to zero between them.
    """

    def f(p):
        sign = np.where(np.floor(p[:, 0] / period) % 2 == 0, 1.0, -1.0)
        return np.stack([np.zeros(len(p)), np.full(len(p), s), sign * eps * s], axis=1)

    return f


class RandomSignField(StressField):
    """Another field's samples with the sign of every direction vector drawn at random."""

    def __init__(self, base: StressField, seed: int = 0) -> None:
        self.base = base
        self.principal = base.principal
        self.scale = base.scale
        self.rng = np.random.default_rng(seed)

    def tensor(self, points):  # noqa: D102
        return self.base.tensor(points)

    def sample(self, points) -> FieldSample:  # noqa: D102
        smp = self.base.with_principal(self.principal).sample(points)
        flip = self.rng.choice([-1.0, 1.0], size=len(smp.direction))
        return FieldSample(
            tensor=smp.tensor,
            sigma=smp.sigma,
            direction=smp.direction * flip[:, None],
            magnitude=smp.magnitude,
            mass=smp.mass,
            anisotropy=smp.anisotropy,
            valid=smp.valid,
            inside=smp.inside,
        )


def open_hole(length=30.0, width=12.0, radius=2.5):
    region = box(0, 0, length, width).difference(Point(length / 2, width / 2).buffer(radius, quad_segs=32))
    centre = (length / 2, width / 2)
    field = AnalyticField(lambda p: kirsch_tensor(p, centre, radius, 10.0), region, scale=30.0)
    return region, field


def two_close_holes():
    """A plate whose second hole sits in the stress concentration of the first.

    The field superposes two Kirsch solutions (minus one remote stress): not an exact elastic
    solution, but a smooth tensor field that curves around both holes and changes fast between them.
    """
    c1, c2, r = (12.0, 8.0), (18.5, 9.0), 2.5
    region = box(0, 0, 30, 16).difference(shapely.union_all([Point(c1).buffer(r), Point(c2).buffer(r)]))

    def f(p):
        t = kirsch_tensor(p, c1, r, 10.0) + kirsch_tensor(p, c2, r, 10.0)
        t[:, 0] -= 10.0
        return t

    return region, AnalyticField(f, region, scale=30.0)


def exact_min_spacing(paths) -> float:
    """Smallest segment-to-segment distance between different paths (inf if fewer than two)."""
    lines = Lines.from_list([p.points for p in paths])
    start, owner = lines.segments()
    if len(start) < 2:
        return float("inf")
    a = lines.points[start]
    b = lines.points[start + 1]
    hmax = float(np.max(np.linalg.norm(b - a, axis=1)))
    pairs = cKDTree(0.5 * (a + b)).query_pairs(2.0 + hmax, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    m = owner[i] != owner[j]
    if not np.any(m):
        return float("inf")
    return float(np.min(segment_distance(a[i[m]], b[i[m]], a[j[m]], b[j[m]])))


def turning_angles(points) -> np.ndarray:
    """Angle between consecutive segments at every interior vertex, degrees."""
    d = np.diff(points, axis=0)
    d = d[np.linalg.norm(d, axis=1) > 1e-9]
    if len(d) < 2:
        return np.zeros(0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    c = np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0)
    return np.degrees(np.arccos(c))
