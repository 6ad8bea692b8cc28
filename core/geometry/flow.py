"""Flow widths of the moves of a G-code file, and the filament diameter they need.

The **flow width** of a move (interface.md) is its extruded cross-section over its height,
``e * (pi D^2 / 4) / (length * height)``, with ``e`` in mm of filament and ``D`` the filament
diameter.  ``D`` comes from the slicer configuration in the file (PrusaSlicer ``filament_diameter``,
Cura ``material_diameter``).  A file without one (CuraEngine run on its own; Cura's GUI stores only
changed settings) is measured instead: the centre lines of the external perimeter and of the first
inner perimeter lie one mean flow width apart in both slicers' models (PrusaSlicer ``(se + sp) / 2``,
Cura ``(w0 + wx) / 2``), and that spacing is a length the filament diameter does not enter.  When the
E-based width at ``D = 1.75 mm`` disagrees with the measured spacing by more than
:data:`CALIBRATE_REL`, ``D = 1.75 / sqrt(ratio)`` (snapped to 1.75, 2.85 or 3.0 mm within 3 %).
:func:`solid_infill_diameter` measures it on the solid infill instead, once the layer geometry is
known (for Cura files).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import shapely
from loadpath.gcode.flavors import Role
from loadpath.gcode.model import Program

if TYPE_CHECKING:
    from loadpath.geometry.model import PrintGeometry

__all__ = [
    "DEFAULT_FILAMENT",
    "CALIBRATE_REL",
    "filament_diameter",
    "solid_infill_diameter",
    "flow_widths",
    "wall_spacing",
]

DEFAULT_FILAMENT = 1.75
"""Filament diameter assumed when the file neither says nor shows otherwise, mm."""

CALIBRATE_REL = 0.2
"""Relative disagreement between E-based widths and wall spacing above which D is measured."""

_COMMON = (1.75, 2.85, 3.0)


def _config_diameter(program: Program) -> float | None:
    for key in ("filament_diameter", "material_diameter"):
        raw = program.config.get(key)
        if raw:
            try:
                d = float(str(raw).split(",")[0].split(";")[0].strip())
            except ValueError:
                continue
            if d > 0:
                return d
    return None


def filament_diameter(program: Program) -> tuple[float, str]:
    """Filament diameter of a file and where it came from.

    Returns
    -------
    diameter : float, mm
    source : {"config", "wall spacing", "default"}
    """
    d = _config_diameter(program)
    if d is not None:
        return d, "config"
    spacing = wall_spacing(program)
    if spacing is not None:
        m = program.moves
        fw = flow_widths(m, DEFAULT_FILAMENT)
        sel = m["extrude"] & np.isin(m["role"], (Role.PERIMETER, Role.EXTERNAL_PERIMETER)) & np.isfinite(fw)
        if sel.any():
            ratio = float(np.median(fw[sel])) / spacing
            if abs(ratio - 1.0) > CALIBRATE_REL:
                d = DEFAULT_FILAMENT / np.sqrt(ratio)
                near = min(_COMMON, key=lambda c: abs(c - d))
                return (near if abs(near - d) <= 0.03 * near else float(d)), "wall spacing"
    return DEFAULT_FILAMENT, "default"


def wall_spacing(program: Program, layers: int = 3) -> float | None:
    """Distance between the external perimeter and the first inner perimeter, mm (None if not found).

    Measured on up to ``layers`` layers from the middle of the print: the 20th percentile of the
    distances from inner-perimeter midpoints to the nearest external-perimeter segment of their layer
    (further loops lie at multiples of it).
    """
    m = program.moves
    ext = m["extrude"] & (m["role"] == Role.EXTERNAL_PERIMETER)
    inner = m["extrude"] & (m["role"] == Role.PERIMETER)
    both = np.intersect1d(np.unique(m["layer"][ext]), np.unique(m["layer"][inner]))
    both = both[both >= 0]
    if len(both) == 0:
        return None
    mid = len(both) // 2
    picks = both[max(0, mid - layers // 2) : mid - layers // 2 + layers]
    dist = []
    for layer in picks:
        e = m[ext & (m["layer"] == layer)]
        i = m[inner & (m["layer"] == layer)]
        segs = shapely.linestrings(np.stack([np.c_[e["x0"], e["y0"]], np.c_[e["x1"], e["y1"]]], axis=1))
        pts = shapely.points((i["x0"] + i["x1"]) / 2, (i["y0"] + i["y1"]) / 2)
        tree = shapely.STRtree(segs)
        _, d = tree.query_nearest(pts, return_distance=True, all_matches=False)
        dist.append(d)
    d = np.concatenate(dist)
    d = d[d > 0.05]
    return float(np.percentile(d, 20)) if len(d) else None


def flow_widths(moves: np.ndarray, diameter: float) -> np.ndarray:
    """Flow width of every move, mm (NaN for moves that do not extrude).

    Parameters
    ----------
    moves : structured array (MOVE_DTYPE)
    diameter : float, mm
        Filament diameter.
    """
    length = np.hypot(moves["x1"] - moves["x0"], moves["y1"] - moves["y0"])
    ok = moves["extrude"] & (length > 0) & (moves["height"] > 0)
    area = np.pi * diameter**2 / 4
    with np.errstate(invalid="ignore", divide="ignore"):
        fw = moves["e"] * area / (length * moves["height"])
    return np.where(ok, fw, np.nan)


def solid_infill_diameter(program: Program, geo: PrintGeometry) -> float | None:
    """Filament diameter from the solid infill of a file without settings (Cura), mm, or None.

    Solid infill tiles its region: its flow width equals its line spacing, so
    ``E * pi d^2 / 4 = pitch * height * length`` gives ``d``.  Snapped to 1.75 or 2.85 mm within 5 %.
    The application uses it on Cura files whose diameter neither the settings nor
    :func:`filament_diameter` (config, wall spacing) gave; the two measurements live here together
    so there is one place that reads a filament diameter off a file.
    """
    ds = []
    for obj in geo.objects:
        for lg in obj.layers:
            for isl in lg.islands:
                for b in isl.blocks:
                    # by the role, which slicers print solid: a kind is no proof (sparse infill on the
                    # first layer of a part without skins is its "bottom": 4 mm apart, d = 5.5 mm)
                    if b.role.is_solid_infill and b.length > 20 and b.pitch > 0:
                        blk = program.block(b.block_index)
                        if blk.e > 0:
                            area = b.pitch * b.height * blk.length / blk.e
                            ds.append(float(np.sqrt(4 * area / np.pi)))
    if not ds:
        return None
    d = float(np.median(ds))
    for std in (1.75, 2.85):
        if abs(d - std) <= 0.05 * std:
            return std
    return d
