"""The stress-field contract between the FEA and the path engines.

A :class:`StressField` answers, for a layer, at any array of points ``(x, y)``: the in-plane stress
tensor (interpolated as a tensor, never as direction vectors, which have no sign), and from it the
followed principal stress ``s = sigma * e``, its magnitude, the anisotropy ``sigma1 - sigma2``, a
validity mask where the direction is undefined, and NaN outside the part.

Subclasses implement only :meth:`StressField.tensor` (and carry the normalising stress
:attr:`StressField.scale`); the decomposition is shared here so every field decomposes the same way.
The FEA provides the finite-element field (``loadpath.fea``); :class:`AnalyticField` wraps a closed
form such as :func:`kirsch_tensor` (infinite plate with a hole), which tests and benchmarks use as a
reference.

Which principal stress is followed (interface.md ``principal``):

``"max_abs"``
    the one with the largest magnitude, ``|sigma1| >= |sigma2|`` (the swarm paper, Sec. II-A); it
    jumps by 90 degrees along the neutral axis of a bent part.
``"min_abs"``
    the other one (used by ``principal = "alternate"`` on every other layer).
``"tensile"``
    the algebraically largest, ``sigma1`` (what Ansys calls S1; the thesis).
``"compressive"``
    the algebraically smallest, ``sigma2``.
"""

from __future__ import annotations

import copy
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Bools, Floats, Points2, Region, Stress2, Vectors2
from loadpath.errors import SettingsError
from loadpath.tolerances import TOL

__all__ = [
    "PRINCIPALS",
    "FieldSample",
    "StressField",
    "AnalyticField",
    "RotatedField",
    "principal_stresses",
    "kirsch_tensor",
]

PRINCIPALS = ("max_abs", "min_abs", "tensile", "compressive")


@dataclass(frozen=True)
class FieldSample:
    """The stress field at ``n`` query points.

    Attributes
    ----------
    tensor : (n, 3) float, MPa
        ``[sxx, syy, sxy]``; NaN outside the part.
    sigma : (n,) float, MPa
        The followed principal stress (signed).
    direction : (n, 2) float
        Unit vector of the followed principal direction (sign arbitrary); NaN outside.
    magnitude : (n,) float, MPa
        ``|sigma|``, the norm of the principal stress vector ``s = sigma * direction``.
    mass : (n,) float
        ``magnitude / scale`` clipped to [0, 1]: the swarm paper's virtual mass (footnote 1) and the
        weight of the alignment metric (Eq. 14); 0 outside.
    anisotropy : (n,) float, MPa
        ``sigma1 - sigma2 >= 0``; where it vanishes the principal direction is undefined.
    valid : (n,) bool
        Inside the part and the direction is defined (anisotropy above
        ``TOL.anisotropy_rel * scale``).
    inside : (n,) bool
        Inside the part.
    """

    tensor: Stress2
    sigma: Floats
    direction: Vectors2
    magnitude: Floats
    mass: Floats
    anisotropy: Floats
    valid: Bools
    inside: Bools


def principal_stresses(tensor: Stress2) -> tuple[Floats, Floats, Vectors2, Vectors2]:
    """Closed-form principal decomposition of 2D stress tensors.

    For ``[sxx, syy, sxy]``: ``c = (sxx + syy) / 2``, ``r = sqrt(((sxx - syy) / 2)^2 + sxy^2)``,
    ``sigma1 = c + r``, ``sigma2 = c - r``, and ``e1`` at angle ``theta = atan2(2 sxy, sxx - syy) / 2``.

    Parameters
    ----------
    tensor : (n, 3) float, MPa
        ``[sxx, syy, sxy]``.

    Returns
    -------
    sigma1, sigma2 : (n,) float, MPa
        Algebraically largest and smallest principal stresses.
    e1, e2 : (n, 2) float
        Their unit directions (sign arbitrary, ``e2`` is ``e1`` turned by +90 degrees).

    Examples
    --------
    >>> s1, s2, e1, e2 = principal_stresses(np.array([[0.0, 0.0, 1.0]]))
    >>> float(s1[0]), float(s2[0])
    (1.0, -1.0)
    """
    t = np.asarray(tensor, dtype=float)
    sxx, syy, sxy = t[:, 0], t[:, 1], t[:, 2]
    c = 0.5 * (sxx + syy)
    r = np.hypot(0.5 * (sxx - syy), sxy)
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    e1 = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    e2 = np.stack([-e1[:, 1], e1[:, 0]], axis=1)
    return c + r, c - r, e1, e2


def _check_principal(which: str) -> str:
    if which not in PRINCIPALS:
        raise SettingsError(
            f"principal = {which!r} is not a principal stress choice; use one of {', '.join(PRINCIPALS)}"
        )
    return which


class StressField(ABC):
    """In-plane stress of one layer, sampled at arbitrary points.

    Attributes
    ----------
    principal : str
        Which principal stress is followed (see the module docstring).
    scale : float, MPa
        Normalising stress: a high percentile of ``|s|`` away from supports and load points, so it
        does not depend on the mesh at a boundary-condition singularity.
    """

    principal: str = "max_abs"
    scale: float = 1.0

    @abstractmethod
    def tensor(self, points: Points2) -> Stress2:
        """Stress tensor at points.

        Parameters
        ----------
        points : (n, 2) float, mm

        Returns
        -------
        (n, 3) float, MPa
            ``[sxx, syy, sxy]``, NaN outside the part.
        """

    def sample(self, points: Points2) -> FieldSample:
        """Decompose the field at points into the followed principal stress.

        Parameters
        ----------
        points : (n, 2) float, mm

        Returns
        -------
        FieldSample
        """
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        t = self.tensor(pts)
        inside = np.all(np.isfinite(t), axis=1)
        s1, s2, e1, e2 = principal_stresses(np.where(inside[:, None], t, 0.0))
        which = self.principal
        if which == "tensile":
            first = np.ones(len(pts), dtype=bool)
        elif which == "compressive":
            first = np.zeros(len(pts), dtype=bool)
        elif which == "max_abs":
            first = np.abs(s1) >= np.abs(s2)
        else:  # min_abs
            first = np.abs(s1) < np.abs(s2)
        sigma = np.where(first, s1, s2)
        direction = np.where(first[:, None], e1, e2)
        aniso = s1 - s2
        magnitude = np.abs(sigma)
        scale = self.scale if self.scale > 0 else 1.0
        mass = np.clip(magnitude / scale, 0.0, 1.0)
        valid = inside & (aniso > TOL.anisotropy_rel * scale)
        nan = np.full(len(pts), np.nan)
        return FieldSample(
            tensor=t,
            sigma=np.where(inside, sigma, nan),
            direction=np.where(inside[:, None], direction, np.nan),
            magnitude=np.where(inside, magnitude, nan),
            mass=np.where(inside, mass, 0.0),
            anisotropy=np.where(inside, aniso, nan),
            valid=valid,
            inside=inside,
        )

    def with_principal(self, which: str) -> StressField:
        """Return a copy of this field that follows another principal stress (``PRINCIPALS``)."""
        other = copy.copy(self)
        other.principal = _check_principal(which)
        return other


class AnalyticField(StressField):
    """A field given by a closed form, restricted to a region.

    Parameters
    ----------
    func : callable
        ``func(points (n, 2) mm) -> (n, 3) MPa``.
    region : shapely Polygon or MultiPolygon, optional
        Where the field is defined; NaN outside.  ``None``: everywhere.
    scale : float, MPa
        Normalising stress.
    principal : str
        One of ``PRINCIPALS``.
    """

    def __init__(
        self,
        func: Callable[[Points2], Stress2],
        region: Region | None = None,
        scale: float = 1.0,
        principal: str = "max_abs",
    ) -> None:
        self.func = func
        self.region = region
        if region is not None:
            shapely.prepare(region)
        self.scale = float(scale)
        self.principal = _check_principal(principal)

    def tensor(self, points: Points2) -> Stress2:  # noqa: D102 (documented in the base class)
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        t = np.asarray(self.func(pts), dtype=float).reshape(-1, 3)
        if self.region is not None:
            inside = shapely.contains_xy(self.region, pts[:, 0], pts[:, 1])
            inside |= shapely.intersects_xy(self.region.boundary, pts[:, 0], pts[:, 1])
            t = np.where(inside[:, None], t, np.nan)
        return t


def kirsch_tensor(
    points: Points2, center: tuple[float, float], radius: float, stress: float, angle: float = 0.0
) -> Stress2:
    """Kirsch's solution: an infinite plate with a circular hole under uniaxial tension.

    With the load ``S`` along the direction at ``angle`` (rad), hole radius ``a`` and polar
    coordinates ``(r, t)`` about the centre, ``t`` measured from the load direction::

        s_rr = S/2 (1 - a²/r²) + S/2 (1 - 4a²/r² + 3a⁴/r⁴) cos 2t
        s_tt = S/2 (1 + a²/r²) - S/2 (1 + 3a⁴/r⁴) cos 2t
        s_rt = -S/2 (1 + 2a²/r² - 3a⁴/r⁴) sin 2t

    so ``s_tt = 3 S`` at the hole edge across the load.  Points inside the hole get NaN.

    Parameters
    ----------
    points : (n, 2) float, mm
    center : (2,) float, mm
    radius : float, mm
    stress : float, MPa
        Remote uniaxial stress ``S``.
    angle : float, rad
        Direction of the load.

    Returns
    -------
    (n, 3) float, MPa
        ``[sxx, syy, sxy]`` in the bed frame.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 2) - np.asarray(center, dtype=float)
    ca, sa = np.cos(angle), np.sin(angle)
    x = p[:, 0] * ca + p[:, 1] * sa
    y = -p[:, 0] * sa + p[:, 1] * ca
    r2 = x * x + y * y
    with np.errstate(divide="ignore", invalid="ignore"):
        q = radius * radius / r2
        t = np.arctan2(y, x)
        c2, s2 = np.cos(2 * t), np.sin(2 * t)
        srr = 0.5 * stress * (1 - q) + 0.5 * stress * (1 - 4 * q + 3 * q * q) * c2
        stt = 0.5 * stress * (1 + q) - 0.5 * stress * (1 + 3 * q * q) * c2
        srt = -0.5 * stress * (1 + 2 * q - 3 * q * q) * s2
    c, s = np.cos(t), np.sin(t)
    # polar -> load frame
    sxx = srr * c * c + stt * s * s - 2 * srt * s * c
    syy = srr * s * s + stt * c * c + 2 * srt * s * c
    sxy = (srr - stt) * s * c + srt * (c * c - s * s)
    # load frame -> bed frame (rotate by angle)
    gxx = sxx * ca * ca + syy * sa * sa - 2 * sxy * sa * ca
    gyy = sxx * sa * sa + syy * ca * ca + 2 * sxy * sa * ca
    gxy = (sxx - syy) * sa * ca + sxy * (ca * ca - sa * sa)
    out = np.stack([gxx, gyy, gxy], axis=1)
    out[r2 < radius * radius * (1 - 1e-12)] = np.nan
    return out


class RotatedField(StressField):
    """A field whose principal directions are another's turned by ``angle`` (magnitudes kept).

    The tensor at every point is the base tensor rotated, ``R(angle) T R(angle)^T``, so paths that
    follow it cross the base field's principal directions at ``angle``: layers at ``+angle`` and
    ``-angle`` about sigma1 brace each other (``principal = "cross"`` of the pipeline).

    Parameters
    ----------
    base : StressField
    angle : float, rad
        Counter-clockwise.
    """

    def __init__(self, base: StressField, angle: float) -> None:
        self.base = base
        self.angle = float(angle)
        self.scale = base.scale
        self.principal = base.principal
        self.load_entry = getattr(base, "load_entry", None)

    def tensor(self, points: Points2) -> Stress2:  # noqa: D102 (documented in the base class)
        t = self.base.tensor(points)
        c, s = np.cos(self.angle), np.sin(self.angle)
        sxx, syy, sxy = t[:, 0], t[:, 1], t[:, 2]
        return np.column_stack(
            [
                c * c * sxx + s * s * syy - 2.0 * c * s * sxy,
                s * s * sxx + c * c * syy + 2.0 * c * s * sxy,
                c * s * (sxx - syy) + (c * c - s * s) * sxy,
            ]
        )
