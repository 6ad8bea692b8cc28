"""Where sparse infill puts its plastic: a density field from the stress analysis.

The replaced sparse infill keeps the slicer's bead width, so its local density (fill) is set by
its pitch alone: lines of flow width ``w`` at pitch ``p`` fill ``rho = w / p`` of the layer.  This
module turns the layer's stress field into ``rho(x)`` and hence a pitch field ``p(x) = w / rho(x)``.

Criterion: an optimality criterion at fixed stress (statically determinate reading of the FE field).
With fill ``rho`` the layer's stiffness along its lines scales as ``rho**k`` (``k = 1`` for lines
that follow the stress, the thesis's linear-density model ``C* = v C(alpha)``, Eq. 3.13-3.15), so
at a fixed stress field the compliance ``int e0(x) / rho(x)**k dA`` (``e0``: strain energy density
of the uniform part) at a fixed plastic ``int rho dA`` is least where ``rho ~ e0 ** (1 / (1 + k))``
(Lagrange condition ``k e0 rho**-(k+1) = lambda``); for ``k = 1`` that is ``rho ~ sqrt(e0)``, which
for a uniaxial state is ``rho ~ |sigma|``: the fully stressed design, the same field the failure
index (strength proportional to fill) asks for.  So:

* ``criterion = "energy"`` (:class:`DensityOptions`' default; the ``density`` setting's default,
  ``"auto"``, lays this one and ``"stack"`` and keeps the better, :mod:`loadpath.plugin.density_choice`):
  ``rho ~ e0 ** exponent`` with ``exponent = 1``.
* ``criterion = "failure"``: ``rho ~ sigma_vm ** exponent`` (von Mises over the yield-type
  strength), ``exponent = 1``: the fully stressed design.
* ``criterion = "stack"``: the fully stressed layer stack, which knows what the skins carry (below).
* ``criterion = "uniform"``: the slicer's own uniform density (nothing moves).

``"stack"``: the sparse layers take the stress the solid layers leave.  In the model of ``loadpath
compare`` every layer of an in-plane part shares one strain field (a laminate), so at a point
carrying the stress ``sigma`` (the isotropic analysis' field, read as statically determinate across
the stack) a stack whose solid share is ``a`` (skins and solid infill, :func:`solid_share`) and whose
sparse layers (share ``b = 1 - a``) lay lines of fill ``rho`` along ``sigma`` strains by
``sigma / (E (a + b rho))``.  Both the compliance at fixed plastic (Lagrange: ``b sigma**2 / (a + b
rho)**2 = lambda``) and the fully stressed design (every ply, skins included, at one strain) ask for
``a + b rho ~ |sigma|``, i.e. ``rho = c |sigma| - a / b``: where the skins alone hold the stress the
sparse layers keep only their minimum, and the plastic goes where the skins would be strained most.
Without skins (``a = 0``) this is ``rho ~ |sigma|``, which does not starve a bending part's web as
``rho ~ e0`` does.  ``sigma`` is the principal stress the lines follow, of largest magnitude (not the
energy norm, which weighs shear by ``2 (1 + nu)`` and drew the plastic to sheared zones the lines do
not brace).  With two families in alternating layers (``principal = "alternate"``: lines along
``sigma_major`` and ``sigma_minor``) each family ``k`` has ``rho_k = c |sigma_k| - 2 a / b`` with one
``c`` for both, so the pair shares its plastic as the two principal stresses ask (a shear web gets
both families, a bending flange the major one).  Measured with ``benchmarks/bench_sparse.py``
(figures in the README's sparse section): the L-bracket, PrusaSlicer gyroid 20 %, failure load over
the slicer's 0.846 (energy) -> 1.017 (stack), stiffness 1.155 -> 1.179; the same stack law on the
energy norm ``sqrt(e0)`` gave 0.828.  It is not better everywhere: the 3-point beam 1.879 -> 1.310
and the shelf bracket 1.389 -> 1.002 (failure load), where the sheared zones near the supports keep
less plastic; hence the setting's default ``"auto"``, which lays both.

Why the energy exponent is 1 and not the fixed-stress optimum 1/2: ``e0`` is the strain energy of the
*uniform* part.  Once the plastic moves to where that energy is, those zones are stiffer and draw
still more of the load (the part is statically indeterminate), so the optimality criterion's fixed
point, which re-solves and updates ``rho`` until it stops changing, has a sharper contrast than one
step from the uniform field; ``exponent = 1`` is that sharper field without the re-solves.
Measured with ``benchmarks/bench_sparse.py`` (PrusaSlicer 2.5 gyroid 20 %, swarm, current model of
``loadpath compare``, stiffness over the slicer's at the same mass): 3-point beam 1.100 (exponent
1/2) -> 1.185 (exponent 1); L-bracket 1.092 -> 1.107.  The failure criterion (von Mises, exponent
1) gave 1.090 (beam), 1.088 (bracket), 1.064 (shelf; energy 1/2: 1.070): below the energy
criterion on every part, so energy is the default.  The two stress criteria differ in multiaxial
states only (``sqrt(e0)`` weighs shear by ``2 (1 + nu)`` where von Mises weighs it by 3).

``rho`` is clamped to ``[rho_min, 1]``.  ``rho_min = w / max_pitch``: a top skin laid over the infill
bridges from line to line, so lines must stay closer than the bridging distance (the thesis's
no-sag limit ``l_max``, 8 mm for its 20 % ABS MBB, §3.1.2 and §3.6).  The clamped field is scaled
(bisection on the Lagrange multiplier) so its mean over the region is the requested fill: by default
the slicer's own, so the part keeps the slicer's mass.  The stress field is smoothed over about a
slicer pitch first: a load point or a support corner is singular in the FE field and would
otherwise take the plastic of a whole region for one cell.

(Over 400 lines: most of it is this docstring, the criteria's derivations and the figures that chose them.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Floats, Points2, Region
from loadpath.errors import SettingsError
from loadpath.field import StressField

__all__ = ["CRITERIA", "CHOICES", "DensityOptions", "DensityField", "density_field", "solid_share"]
__all__ += ["MAX_PITCH_MM"]

_SOLID_KINDS = ("solid", "top", "bottom", "bridge")

CRITERIA = ("energy", "failure", "stack", "uniform")
"""The criteria :func:`density_field` computes."""

CHOICES = ("auto", *CRITERIA)
"""What the ``density`` setting takes: a criterion, or ``"auto"`` (the run lays ``"energy"`` and
``"stack"`` and keeps the one the mechanics model predicts better, :mod:`loadpath.plugin.density_choice`)."""

MAX_PITCH_MM = 8.0
"""Default widest pitch: the thesis's no-sag limit for its 20 % MBB beam (§3.1.2, §3.6), mm."""

_EXPONENT = {"energy": 1.0, "failure": 1.0, "stack": 0.5, "uniform": 0.0}


@dataclass(frozen=True)
class DensityOptions:
    """How the density field is made.

    Attributes
    ----------
    criterion : {"energy", "failure", "stack", "uniform"}
        What sets the density (module docstring).
    exponent : float or None
        ``rho ~ measure ** exponent``; None: the criterion's default (energy 1, failure 1, stack
        1/2 on the strain energy density, i.e. the stress).
    fill : float or None
        Mean fill of the replaced sparse infill, 0-1; None: the slicer's own (same mass).
    max_pitch : float, mm
        Widest pitch (sets ``rho_min = w / max_pitch``): top skins need supports this close.
    cell : float or None, mm
        Grid cell; None: a quarter of the slicer's pitch, at least 0.25 mm.
    solid_share : float
        ``criterion = "stack"``: share ``a`` of the part's layer stack over the region that is
        printed solid (skins, solid infill), 0-0.95; set by the pipeline from the slicer's layers
        (:func:`solid_share`), not by the user.
    family : {None, "major", "minor"}
        ``criterion = "stack"`` with two families of lines in alternating layers (``principal =
        "alternate"``): which one this layer lays, along the principal stress of largest (``"major"``)
        or smallest (``"minor"``) magnitude.  Set by the pipeline.
    """

    criterion: str = "energy"
    exponent: float | None = None
    fill: float | None = None
    max_pitch: float = MAX_PITCH_MM
    cell: float | None = None
    solid_share: float = 0.0
    family: str | None = None

    def __post_init__(self) -> None:
        if self.criterion not in CRITERIA:
            raise SettingsError(f"density = {self.criterion!r} is unknown; use one of {', '.join(CRITERIA)}")
        if self.fill is not None and not (0.0 < self.fill <= 1.0):
            raise SettingsError(
                f"sparse_fill = {self.fill!r} must be a fraction in (0, 1], e.g. 0.2 for 20 %"
            )
        if not (self.max_pitch > 0 and np.isfinite(self.max_pitch)):
            raise SettingsError(f"density_max_pitch = {self.max_pitch!r} mm must be a positive number")
        if self.exponent is not None and not (0.0 <= self.exponent <= 4.0):
            raise SettingsError(f"density_exponent = {self.exponent!r} must lie in [0, 4]")
        if self.family not in (None, "major", "minor"):
            raise SettingsError(f"density family {self.family!r} is unknown; use 'major' or 'minor'")
        if not (0.0 <= self.solid_share <= 0.95):
            raise SettingsError(f"solid share {self.solid_share!r} of the layer stack must lie in [0, 0.95]")

    @property
    def power(self) -> float:
        """The exponent in use."""
        return _EXPONENT[self.criterion] if self.exponent is None else float(self.exponent)


@dataclass(frozen=True)
class DensityField:
    """Fill and pitch of the sparse infill on a grid over one region.

    Attributes
    ----------
    origin : (2,) float, mm
        Centre of cell ``[0, 0]``.
    cell : float, mm
    rho : (ny, nx) float
        Fill 0-1 (``rho[j, i]`` at ``origin + (i, j) * cell``); NaN outside the region.
    pitch : (ny, nx) float, mm
        ``flow_width / rho``; NaN outside.
    flow_width : float, mm
    mean : float
        Area mean of ``rho`` over the region (the fill it was scaled to, unless ``reached`` is False).
    rho_min : float
    criterion : str
    exponent : float
    reached : bool
        Whether the requested mean fill was reached (False: it lies outside ``[rho_min, 1]``, the
        field is then all ``rho_min`` or all 1).
    """

    origin: Floats
    cell: float
    rho: np.ndarray
    pitch: np.ndarray
    flow_width: float
    mean: float
    rho_min: float
    criterion: str
    exponent: float
    reached: bool

    def sample(self, points: Points2) -> Floats:
        """Fill at points (nearest cell; cells outside the region take the nearest inside), (n,)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ny, nx = self.rho.shape
        i = np.clip(np.rint((pts[:, 0] - self.origin[0]) / self.cell).astype(int), 0, nx - 1)
        j = np.clip(np.rint((pts[:, 1] - self.origin[1]) / self.cell).astype(int), 0, ny - 1)
        return self._filled[j, i]

    def pitch_at(self, points: Points2) -> Floats:
        """Pitch at points, (n,) mm."""
        return self.flow_width / self.sample(points)

    @property
    def _filled(self) -> np.ndarray:
        cached = self.__dict__.get("_filled_cache")
        if cached is None:
            from scipy.ndimage import distance_transform_edt

            bad = ~np.isfinite(self.rho)
            if bad.all():
                cached = np.full(self.rho.shape, self.mean)
            else:
                idx = distance_transform_edt(bad, return_distances=False, return_indices=True)
                cached = self.rho[tuple(idx)]
            object.__setattr__(self, "_filled_cache", cached)
        return cached

    @property
    def base_pitch(self) -> float:
        """Pitch of a uniform fill at the field's mean, mm (the run's nominal pitch scales the zones)."""
        return self.flow_width / self.mean

    def levels(self, n: int) -> Floats:
        """``n`` pitches (mm, ascending) spaced evenly in ``log(pitch)`` over the field's range."""
        p = self.pitch[np.isfinite(self.pitch)]
        lo, hi = float(np.min(p)), float(np.max(p))
        if hi <= lo * 1.0001 or n <= 1:
            return np.array([self.flow_width / self.mean])
        return np.exp(np.linspace(np.log(lo), np.log(hi), n))


def _principal_magnitudes(field: StressField, pts: Points2) -> tuple[Floats, Floats]:
    """Largest and smallest principal stress magnitude at points, (n,) and (n,) MPa."""
    t = field.tensor(pts)
    c, r = 0.5 * (t[:, 0] + t[:, 1]), np.hypot(0.5 * (t[:, 0] - t[:, 1]), t[:, 2])
    a, b = np.abs(c + r), np.abs(c - r)
    return np.maximum(a, b), np.minimum(a, b)


def _measure(field: StressField, pts: Points2, criterion: str, nu: float) -> Floats:
    t = field.tensor(pts)
    sxx, syy, sxy = t[:, 0], t[:, 1], t[:, 2]
    if criterion == "failure":
        m = np.sqrt(np.maximum(sxx**2 - sxx * syy + syy**2 + 3.0 * sxy**2, 0.0))
    else:  # strain energy density * 2E (E only scales it)
        m = np.maximum(sxx**2 + syy**2 - 2.0 * nu * sxx * syy + 2.0 * (1.0 + nu) * sxy**2, 0.0)
    return m


def _smooth(values: np.ndarray, inside: np.ndarray, sigma_cells: float) -> np.ndarray:
    """Gaussian smoothing of ``values`` over the cells ``inside`` only (normalised convolution)."""
    from scipy.ndimage import gaussian_filter

    v = np.where(inside, values, 0.0)
    w = gaussian_filter(inside.astype(float), sigma_cells, mode="constant")
    s = gaussian_filter(v, sigma_cells, mode="constant")
    return np.where(inside, s / np.maximum(w, 1e-12), np.nan)


def _scale_to_mean(s: Floats, target: float, rho_min: float, offset: float = 0.0) -> tuple[Floats, bool]:
    """``clip(c * s - offset, rho_min, 1)`` with ``c`` such that its mean is ``target`` (bisection)."""
    if target <= rho_min + 1e-12:
        return np.full_like(s, rho_min), target >= rho_min - 1e-9
    if target >= 1.0 - 1e-12:
        return np.ones_like(s), target <= 1.0 + 1e-9
    if np.ptp(s) <= 1e-12 * max(float(np.max(s)), 1e-30):
        return np.full_like(s, target), True
    top = float(np.max(s))
    lo, hi = 0.0, (1.0 + offset) / max(float(np.min(s[s > 0], initial=top)), 1e-30) * 2.0
    for _ in range(200):
        c = 0.5 * (lo + hi)
        m = float(np.mean(np.clip(c * s - offset, rho_min, 1.0)))
        if abs(m - target) < 1e-10:
            break
        if m < target:
            lo = c
        else:
            hi = c
    rho = np.clip(c * s - offset, rho_min, 1.0)
    return rho, bool(abs(float(np.mean(rho)) - target) < 1e-6)


def _graded(values: Floats, inside: np.ndarray, sigma: float, power: float) -> Floats:
    """A measure at the cells ``inside`` smoothed over ``sigma`` cells and raised to ``power``, (n,)."""
    m = np.full(inside.shape, np.nan)
    m[inside] = values
    ok = inside & np.isfinite(m)
    # cells the field does not reach (a sliver outside the mesh) take the region's median
    m = np.where(inside & ~np.isfinite(m), np.nanmedian(m[ok]) if ok.any() else 1.0, m)
    s = np.maximum(_smooth(m, inside, sigma)[inside], 0.0) ** power
    return s if np.any(s > 0) else np.ones_like(s)


def _stack(
    field: StressField,
    pts: Points2,
    inside: np.ndarray,
    sigma: float,
    power: float,
    target: float,
    rho_min: float,
    opt: DensityOptions,
) -> tuple[Floats, bool]:
    """The ``"stack"`` fill of one layer's cells (module docstring), (n,) and whether it was reached.

    One family (``opt.family`` None): ``rho = c |sigma_major| - a / (1 - a)``.  Two families in
    alternating layers: ``rho_k = c |sigma_k| - 2 a / (1 - a)`` with one ``c`` for both, scaled so
    the two layers together keep twice ``target``; this layer's family is returned.
    """
    major, minor = _principal_magnitudes(field, pts)
    a = opt.solid_share
    if opt.family is None:
        return _scale_to_mean(_graded(major, inside, sigma, 2.0 * power), target, rho_min, a / (1.0 - a))
    both = np.concatenate([_graded(m, inside, sigma, 2.0 * power) for m in (major, minor)])
    rho, reached = _scale_to_mean(both, target, rho_min, 2.0 * a / (1.0 - a))
    n = len(major)
    return (rho[:n] if opt.family == "major" else rho[n:]), reached


def density_field(
    field: StressField,
    region: Region,
    flow_width: float,
    slicer_pitch: float,
    options: DensityOptions | None = None,
    poissons_ratio: float = 0.35,
) -> DensityField:
    """Density (fill) and pitch of new sparse infill over one region.

    Parameters
    ----------
    field : StressField
        The layer's stress field (isotropic analysis of the load case).
    region : Polygon or MultiPolygon, mm
        The replace region.
    flow_width : float, mm
        Bead flow width of the sparse infill (fixed; density is set by the pitch).
    slicer_pitch : float, mm
        The pitch that lays the slicer's plastic per area (its fill is ``flow_width / slicer_pitch``).
    options : DensityOptions, optional
    poissons_ratio : float
        Of the analysis' material (weighs shear in the strain energy density).

    Returns
    -------
    DensityField
    """
    opt = options or DensityOptions()
    if not (flow_width > 0 and slicer_pitch > 0):
        raise SettingsError(f"flow width {flow_width!r} and pitch {slicer_pitch!r} mm must be positive")
    target = float(opt.fill) if opt.fill is not None else min(1.0, flow_width / slicer_pitch)
    rho_min = min(1.0, flow_width / opt.max_pitch)
    cell = float(opt.cell or max(0.25, 0.25 * slicer_pitch))
    x0, y0, x1, y1 = region.bounds
    xs = np.arange(x0 + 0.5 * cell, x1, cell)
    ys = np.arange(y0 + 0.5 * cell, y1, cell)
    if len(xs) == 0 or len(ys) == 0:
        xs, ys = np.array([0.5 * (x0 + x1)]), np.array([0.5 * (y0 + y1)])
    gx, gy = np.meshgrid(xs, ys)
    inside = shapely.contains_xy(region, gx, gy)
    if not inside.any():
        c = region.representative_point()
        gx, gy = np.array([[c.x]]), np.array([[c.y]])
        xs, ys = gx[0], gy[:, 0]
        inside = np.ones((1, 1), dtype=bool)
    power = opt.power
    pts = np.column_stack([gx[inside], gy[inside]])
    sigma = max(1.0, slicer_pitch / cell)
    if opt.criterion == "uniform" or power == 0.0:
        rho_in, reached = _scale_to_mean(np.ones(int(inside.sum())), target, rho_min)
    elif opt.criterion == "stack":
        rho_in, reached = _stack(field, pts, inside, sigma, power, target, rho_min, opt)
    else:
        s = _graded(_measure(field, pts, opt.criterion, poissons_ratio), inside, sigma, power)
        rho_in, reached = _scale_to_mean(s, target, rho_min)
    rho = np.full(gx.shape, np.nan)
    rho[inside] = rho_in
    return DensityField(
        origin=np.array([xs[0], ys[0]]),
        cell=cell,
        rho=rho,
        pitch=flow_width / rho,
        flow_width=float(flow_width),
        mean=float(np.mean(rho_in)),
        rho_min=rho_min,
        criterion=opt.criterion,
        exponent=power,
        reached=reached,
    )



def solid_share(obj) -> float:  # type: ignore[no-untyped-def]
    """Share of an object's infill, by volume, that the slicer prints solid (``a`` of ``"stack"``).

    Parameters
    ----------
    obj : loadpath.geometry.ObjectGeometry
        The object's layers and their infill blocks.

    Returns
    -------
    float
        ``sum h A_solid / sum h A`` over the object's layers, with ``A`` the area of the blocks'
        regions (skins, solid infill and bridges solid; sparse infill not), capped at 0.95; 0 when
        the object has no infill.
    """
    solid = total = 0.0
    for lg in obj.layers:
        for isl in lg.islands:
            for b in isl.blocks:
                if b.kind in _SOLID_KINDS or b.kind == "sparse":
                    v = float(b.region.area) * float(lg.height)
                    total += v
                    solid += v if b.kind in _SOLID_KINDS else 0.0
    return min(0.95, solid / total) if total > 0 else 0.0
