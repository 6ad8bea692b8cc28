"""What a path engine takes and returns.

Both engines (``loadpath.engines.swarm`` and ``loadpath.engines.streamlines``) are functions
``generate(inp: EngineInput, params) -> Toolpaths``; the splicer turns a :class:`Toolpaths` into
G-code, using each point's local pitch to set the flow (variable bead width).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from loadpath._typing import Floats, Points2, Region
from loadpath.errors import SettingsError
from loadpath.field import StressField
from shapely.geometry.base import BaseGeometry

__all__ = ["EngineInput", "Path", "Toolpaths"]


@dataclass(frozen=True)
class EngineInput:
    """Inputs of a path engine for one island of one layer.

    Attributes
    ----------
    region : shapely Polygon or MultiPolygon, mm
        The replace region (with holes, possibly several islands).
    field : StressField
        The layer's stress field; already set to the principal stress to follow.
    pitch : float, mm
        Nominal centre-to-centre distance between neighbouring paths (the paper's l).
    load_entry : shapely geometry or None
        Where the load enters this layer (the boundary pieces the load selectors picked, as lines),
        or None when it does not enter here; the swarm starts its first front there.
    seed : int
        Seed for any randomised choice, so the same input gives the same paths.
    density : loadpath.density.DensityField or None
        A spatially varying pitch (sparse infill dense where the part works): ``pitch`` is then the
        nominal pitch at the field's mean fill and the local pitch is
        ``density.pitch_at(x) * pitch / density.base_pitch`` (:func:`loadpath.engines.generate`).
    """

    region: Region
    field: StressField
    pitch: float
    load_entry: BaseGeometry | None = None
    seed: int = 0
    density: Any = None

    def __post_init__(self) -> None:
        if not (self.pitch > 0 and np.isfinite(self.pitch)):
            raise SettingsError(f"pitch = {self.pitch!r} mm must be a positive number of millimetres")
        if self.region.is_empty:
            raise SettingsError("the replace region is empty; there is nothing to fill")


@dataclass(frozen=True)
class Path:
    """One print path (a polyline printed without travel).

    Attributes
    ----------
    points : (n, 2) float, mm
        Vertices, n >= 2.
    pitch : (n,) float, mm
        Local centre-to-centre distance to the neighbouring paths at each vertex; the splicer sets
        the bead's flow width from it.
    kind : str
        ``"continuous"`` (a main path) or ``"fill"`` (a gap-filling piece).
    """

    points: Points2
    pitch: Floats
    kind: str = "continuous"

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=float)
        pitch = np.asarray(self.pitch, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
            raise ValueError(f"a path needs an (n >= 2, 2) array of points, got shape {pts.shape}")
        if pitch.shape != (len(pts),):
            raise ValueError(f"pitch must have shape ({len(pts)},), got {pitch.shape}")
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "pitch", pitch)

    @property
    def length(self) -> float:
        """Length of the polyline, mm."""
        return float(np.sum(np.linalg.norm(np.diff(self.points, axis=0), axis=1)))

    @property
    def area(self) -> float:
        """What the path covers at its local pitch: each segment's length times its ends' mean
        pitch, mm^2."""
        seg = np.hypot(*np.diff(self.points, axis=0).T)
        return float(np.sum(seg * 0.5 * (self.pitch[1:] + self.pitch[:-1])))


@dataclass(frozen=True)
class Toolpaths:
    """The paths an engine produced for one region, in print order.

    Attributes
    ----------
    paths : tuple of Path
    stats : dict
        Engine diagnostics (time per stage in s, solver statuses, counts); JSON-serialisable.
    band : Polygon or MultiPolygon or None, mm
        Where the paths end inside the region by design (the level-set engine's cut along a jump of
        the followed direction): the linking joins the ends on it along its edge, as it joins the
        ends on the region's edge (:func:`loadpath.engines.linking.link_paths`).  None: nowhere.
    """

    paths: tuple[Path, ...]
    stats: dict[str, Any] = field(default_factory=dict)
    band: Region | None = None

    @property
    def total_length(self) -> float:
        """Summed length of all paths, mm."""
        return float(sum(p.length for p in self.paths))
