"""Flow models: how much filament a bead of a given width and height takes (E per mm of path).

Facts (``../shared/docs/slicer-conventions.md`` §9, verified on real output):

================  =======================================  ==========================================
model             cross-section ``A(w, h)``                 neighbouring beads tile at a pitch of
================  =======================================  ==========================================
``"rounded"``     ``(w - h) h + pi (h / 2)^2`` (PrusaSlicer  ``w - h (1 - pi / 4)`` (0.4071 mm for
                  and its descendants: a rectangle with     w = 0.45, h = 0.2)
                  half-disc sides)
``"rectangle"``   ``w h`` (Cura)                            ``w``
================  =======================================  ==========================================

E per mm of path is ``A / (pi D^2 / 4) * multiplier`` (filament diameter ``D``; PrusaSlicer's
``extrusion_multiplier``, Cura's ``material_flow`` / 100), or ``A * multiplier`` in mm^3 when the file
uses volumetric E (PrusaSlicer ``use_volumetric_e``).  Examples: w 0.45, h 0.2, D 1.75, rounded:
0.0338488 mm/mm (a real 148.736 mm perimeter has E 5.03452); w 0.4, h 0.2, D 1.75, rectangle:
0.0332601 mm/mm.

The **flow width** of interface.md is ``A / h``: for both models, beads at pitch ``p`` tile the
plane exactly when their flow width is ``p``, so the splicer extrudes ``A = p h`` at a point whose
local pitch is ``p`` and writes the matching bead width (``;WIDTH:``) from :meth:`FlowModel.bead_width`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from loadpath.errors import SettingsError

__all__ = ["FlowModel", "SHAPES"]

SHAPES = ("rounded", "rectangle")
"""Cross-section models: PrusaSlicer's rounded rectangle, Cura's rectangle."""

_ROUND_LOSS = 1.0 - math.pi / 4.0  # (w - flow width) / h for the rounded model


@dataclass(frozen=True)
class FlowModel:
    """A slicer's extrusion model.

    Attributes
    ----------
    shape : {"rounded", "rectangle"}
    filament_diameter : float, mm
    multiplier : float
        Extrusion multiplier (PrusaSlicer ``extrusion_multiplier``, Cura ``material_flow / 100``).
    volumetric : bool
        E words are mm^3 of material (PrusaSlicer ``use_volumetric_e``) instead of mm of filament.

    Examples
    --------
    >>> round(FlowModel("rounded", 1.75).e_per_mm(0.45, 0.2), 7)
    0.0338488
    >>> round(FlowModel("rectangle", 1.75).e_per_mm(0.4, 0.2), 7)
    0.0332601
    """

    shape: str
    filament_diameter: float
    multiplier: float = 1.0
    volumetric: bool = False

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise SettingsError(f"flow model {self.shape!r} is unknown; use one of {', '.join(SHAPES)}")
        if not (self.filament_diameter > 0 and math.isfinite(self.filament_diameter)):
            raise SettingsError(
                f"filament diameter = {self.filament_diameter!r} mm must be positive (1.75 or 2.85 usually)"
            )
        if not (self.multiplier > 0 and math.isfinite(self.multiplier)):
            raise SettingsError(f"extrusion multiplier = {self.multiplier!r} must be positive (1.0 usually)")

    @property
    def filament_area(self) -> float:
        """Cross-section of the filament, mm^2."""
        return math.pi * self.filament_diameter**2 / 4.0

    def area(self, width, height):
        """Bead cross-section, mm^2.

        Parameters
        ----------
        width : float or (n,) float, mm
            Bead width (the slicer's ``;WIDTH:``).
        height : float or (n,) float, mm
            Layer (bead) height.
        """
        w = np.asarray(width, dtype=float)
        h = np.asarray(height, dtype=float)
        a = (w - h) * h + math.pi * h * h / 4.0 if self.shape == "rounded" else w * h
        return float(a) if a.ndim == 0 else a

    def flow_width(self, width, height):
        """Flow width ``A / h`` of a bead (= the pitch at which such beads tile), mm."""
        w = np.asarray(width, dtype=float)
        out = w - np.asarray(height, dtype=float) * _ROUND_LOSS if self.shape == "rounded" else w * 1.0
        return float(out) if out.ndim == 0 else out

    def bead_width(self, flow_width, height):
        """Bead width whose flow width is ``flow_width`` (inverse of :meth:`flow_width`), mm."""
        fw = np.asarray(flow_width, dtype=float)
        out = fw + np.asarray(height, dtype=float) * _ROUND_LOSS if self.shape == "rounded" else fw * 1.0
        return float(out) if out.ndim == 0 else out

    def e_per_mm(self, width, height):
        """E per mm of path for a bead, in the file's E units (mm of filament or mm^3)."""
        return self.e_for_area(self.area(width, height))

    def e_for_area(self, area):
        """E per mm of path for a cross-section ``area`` (mm^2), in the file's E units."""
        a = np.asarray(area, dtype=float) * self.multiplier
        out = a if self.volumetric else a / self.filament_area
        return float(out) if out.ndim == 0 else out

    def filament_mm(self, e):
        """Millimetres of filament for E in the file's units (identity unless volumetric)."""
        e = np.asarray(e, dtype=float)
        out = e / self.filament_area if self.volumetric else e * 1.0
        return float(out) if out.ndim == 0 else out

    def volume(self, filament_mm):
        """Material volume, mm^3, of a filament length in mm (before the multiplier)."""
        return float(np.sum(filament_mm)) * self.filament_area
