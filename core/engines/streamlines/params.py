"""Parameters of the streamline engine, for its two modes.

``"faithful"`` reproduces the thesis (Murugan, Ch. 4 and App. C; ``../shared/seeds/thesis-digest.md``
§0-1): Table 4.1's ``w = 0.5`` mm, ``h = 0.2`` mm, ``G_p = -0.05`` mm (so the spacing test is
``D >= w + G_p = 0.45`` mm), forward-Euler steps of ``d_L = 0.3`` mm, seeds spread at 0.2 per mm²
(Table 4.3's densest rule, case A) unless the caller passes the mesh's element centroids, the
tensile principal stress (Ansys S1), constant-width beads of ``w``, gap filling on (App. C: only
if ``ol >= 0``, i.e. ``G_p <= 0``), and no minimum length nor turning limit (the thesis has none).

``"default"`` is the fast engine that goes beyond the thesis: RK2 steps of one pitch, spacing
kept between ``min_spacing`` and what the widest bead can bridge, variable bead width clamped to
what the nozzle can print (``width_range`` times ``nozzle``; 0.6-1.6 x 0.4 mm by default), a
minimum filament length and a maximum turning angle.

All lengths in mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from loadpath.errors import SettingsError

__all__ = ["MODES", "StreamlineParams", "resolve_params"]

MODES = ("default", "faithful")


@dataclass(frozen=True)
class StreamlineParams:
    """Resolved parameters (see :func:`resolve_params` for the defaults of each mode).

    Attributes
    ----------
    mode : {"default", "faithful"}
    pitch : float, mm
        Nominal centre-to-centre distance the engine aims for (faithful: ``w + G_p``).
    step : float, mm
        Integration step (the thesis's ``d_L``).
    method : {"rk2", "euler"}
        ``"euler"`` is the thesis's Eq. 4.2; ``"rk2"`` the midpoint rule.
    min_spacing : float, mm
        No two paths come closer than this (segment to segment).  Faithful: ``w + G_p``, tested
        as the thesis does, on Delaunay circumcircle diameters.
    fill_spacing : float, mm
        A gap is filled when a point is at least this far from every path (default mode); the
        faithful gap test is Eq. 4.6, a circumcircle diameter of ``2 (w + G_p)``.
    width_min, width_max : float, mm
        Clamp of the local pitch written on each vertex (the splicer derives the bead width from
        it).  Faithful: both ``w`` (the thesis extrudes a constant ``w x h`` bead).
    min_length : float, mm
        Filaments shorter than this are dropped.
    max_turn_deg : float, degrees
        Largest angle between consecutive steps; a streamline stops before a sharper turn.
    max_length : float, mm
        Guard against endless tracing (closed trajectories around a degenerate point); 0 = from
        the region's size.
    seed_density : float, per mm²
        Faithful seeds per unit area when no seeds are given.
    seeding : {"density", "centroids"}
        Faithful seeds: a hexagonal lattice at ``seed_density``, or the centroids of the FE
        elements (the thesis's choice, Sec. 4.2) when the field is a finite-element field
        (it has ``corners``), inside the region.
    boundary_seed_gap : float, mm
        Default mode: largest distance between boundary seeds where the field runs along the
        boundary.
    gap_fill : bool
        Fill the gaps left by the continuous filaments.
    max_waves : int
        Default mode: bound on the gap-filling rounds.
    max_fill_iterations : int
        Faithful mode: bound on the one-circle-at-a-time gap-filling loop (0 = from the area).
    grid_spacing : float, mm
        Spacing of the grid on which the direction field is cached (0 = automatic).
    w, layer_height, G_p : float, mm
        The thesis's bead width, layer height and minimum gap (faithful mode).
    principal : str or None
        Principal stress to follow; None keeps the field's own (faithful: ``"tensile"``).
    extend_ends : bool
        Default mode: carry every path end on to the next bead or the region's edge
        (:func:`loadpath.engines.finish.ends.extend_ends`), so ends stopped by the spacing check
        leave no void in front of them.
    phase : float, pitches
        Default mode: the boundary seeds, one pitch apart, move on along the boundary by this many
        pitches (:func:`~loadpath.engines.streamlines.seeding.boundary_seeds`); 0.5 lays a layer
        whose paths run between those of phase 0 (the pipeline's staggered copy of a run of
        identical layers).  Faithful mode has no boundary seeds and takes only 0.
    """

    mode: str
    pitch: float
    step: float
    method: str
    min_spacing: float
    fill_spacing: float
    width_min: float
    width_max: float
    min_length: float
    max_turn_deg: float
    max_length: float = 0.0
    seed_density: float = 0.2
    seeding: str = "density"
    boundary_seed_gap: float = 5.0
    gap_fill: bool = True
    max_waves: int = 6
    max_fill_iterations: int = 0
    grid_spacing: float = 0.0
    w: float = 0.5
    layer_height: float = 0.2
    G_p: float = -0.05
    principal: str | None = None
    extend_ends: bool = True
    phase: float = 0.0

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise SettingsError(f"streamlines mode = {self.mode!r} is unknown; use one of {', '.join(MODES)}")
        if self.method not in ("rk2", "euler"):
            raise SettingsError(f"streamlines method = {self.method!r} is unknown; use 'rk2' or 'euler'")
        for name in ("pitch", "step", "min_spacing", "fill_spacing", "width_min", "width_max"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SettingsError(f"streamlines {name} = {v!r} mm must be a positive number")
        if self.width_min > self.width_max:
            raise SettingsError(
                f"streamlines width range {self.width_min:g}..{self.width_max:g} mm is empty; "
                "give width_min <= width_max"
            )
        if self.seeding not in ("density", "centroids"):
            raise SettingsError(f"streamlines seeding = {self.seeding!r}; use 'density' or 'centroids'")
        if not 0 < self.max_turn_deg <= 180:
            raise SettingsError(f"streamlines max_turn_deg = {self.max_turn_deg!r} must be in (0, 180]")
        if self.min_length < 0 or self.max_length < 0:
            raise SettingsError("streamlines min_length and max_length must be >= 0 mm")
        if not (isinstance(self.phase, (int, float)) and math.isfinite(self.phase)):
            raise SettingsError(f"streamlines phase = {self.phase!r} must be a finite number of pitches")
        if self.mode == "faithful" and self.phase != 0:
            raise SettingsError(
                f"streamlines phase = {self.phase!r} is a default-mode option (its boundary seeds); "
                "faithful mode takes phase = 0"
            )
        if self.mode == "faithful" and not self.w + self.G_p > 0:
            raise SettingsError(
                f"w + G_p = {self.w + self.G_p:g} mm must be positive (the thesis's filament spacing)"
            )

    @property
    def max_turn(self) -> float:
        """Largest turning angle per step, rad."""
        return math.radians(self.max_turn_deg)


_DEFAULT_KEYS = {f.name for f in fields(StreamlineParams)} - {"mode"}


def resolve_params(mode: str, pitch: float, **options: Any) -> StreamlineParams:
    """Defaults of a mode for a nominal pitch, overridden by ``options``.

    Parameters
    ----------
    mode : {"default", "faithful"}
    pitch : float, mm
        The nominal pitch of the engine input (ignored by faithful mode, which uses ``w + G_p``).
    **options
        Any :class:`StreamlineParams` field, plus for the default mode ``nozzle`` (mm, 0.4),
        ``width_range`` (multiples of the nozzle, ``(0.6, 1.6)``) and ``flow_width`` (the slicer's
        flow width at the nominal pitch, mm; default: the pitch, as for solid infill).

    Returns
    -------
    StreamlineParams
    """
    if mode not in MODES:
        raise SettingsError(f"streamlines mode = {mode!r} is unknown; use one of {', '.join(MODES)}")
    opts = dict(options)
    nozzle = float(opts.pop("nozzle", 0.4))
    width_range = tuple(opts.pop("width_range", (0.6, 1.6)))
    flow_width = float(opts.pop("flow_width", pitch))
    unknown = sorted(set(opts) - _DEFAULT_KEYS)
    if unknown:
        raise SettingsError(
            f"unknown streamlines option(s) {', '.join(unknown)}; known: "
            f"{', '.join(sorted(_DEFAULT_KEYS | {'nozzle', 'width_range', 'flow_width'}))}"
        )
    if not (nozzle > 0 and len(width_range) == 2 and 0 < width_range[0] <= width_range[1]):
        raise SettingsError(
            f"nozzle = {nozzle!r} mm and width_range = {width_range!r} must be positive, low <= high"
        )
    if mode == "faithful":
        w = float(opts.get("w", 0.5))
        gp = float(opts.get("G_p", -0.05))
        base = StreamlineParams(
            mode="faithful",
            pitch=w + gp if w + gp > 0 else w,
            step=0.3,  # d_L (Table 4.1)
            method="euler",  # Eq. 4.2
            min_spacing=w + gp if w + gp > 0 else w,  # Eq. 4.5
            fill_spacing=2.0 * (w + gp) if w + gp > 0 else w,  # Eq. 4.6 (text), see gapfill.py
            width_min=w,
            width_max=w,
            min_length=0.0,  # no minimum length in the thesis (digest §6)
            max_turn_deg=90.0,  # only the sign rule's bound (digest §1.3): no turning limit
            seed_density=0.2,  # Table 4.3, case A (the densest of the three rules)
            gap_fill=gp <= 0,  # App. C: "to be included only if ol >= 0"
            w=w,
            G_p=gp,
            principal="tensile",  # Ansys S1 (digest §0)
        )
        return replace(base, **opts)
    # default mode: bead widths the nozzle can print, scaled to this pitch's flow
    scale = pitch / flow_width
    wmin = width_range[0] * nozzle * scale
    wmax = width_range[1] * nozzle * scale
    if wmax < pitch:  # a pitch wider than the widest bead (sparse infill): widths follow the pitch
        wmax = 1.4 * pitch
    dmin = min(max(0.7 * pitch, wmin), 0.5 * wmax)
    base = StreamlineParams(
        mode="default",
        pitch=pitch,
        step=4.0 / 3.0 * pitch,  # 0.6 mm at a 0.45 mm pitch; RK2 error ~ (step / radius)^3
        method="rk2",
        min_spacing=dmin,
        fill_spacing=max(0.5 * wmax, dmin),
        width_min=wmin,
        width_max=wmax,
        min_length=3.0 * pitch,
        max_turn_deg=35.0,
        boundary_seed_gap=max(20.0, 50.0 * pitch),
    )
    return replace(base, **opts)
