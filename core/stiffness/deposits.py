"""What a print deposits: straight beads with their volume, from G-code moves or from engine paths.

A :class:`Deposits` is the material the printer lays down, segment by segment: the centre line, the
layer it belongs to (its bottom and height), and the material volume.  The stiffness model needs
nothing else: the bead's **flow width** (interface.md) is ``volume / (length * height)``, whatever
the slicer's flow model, so over- and under-extrusion show up as more or less material.

Sources: :func:`from_program` (the extrusions of one object of a G-code file; E in mm of filament
times the filament cross-section) and :func:`from_toolpaths` (an engine's paths, each point's local
pitch as its flow width, as the splicer extrudes them).  :meth:`Deposits.concat` and
:meth:`Deposits.select` combine them, e.g. a slicer file's perimeters with an engine's infill.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats, Ints, Points2
from loadpath.errors import GeometryError
from loadpath.gcode.flavors import Role
from loadpath.gcode.model import Program
from loadpath.toolpath import Path, Toolpaths

__all__ = ["Deposits", "Stack", "from_program", "from_toolpaths", "PART_ROLES"]

PART_ROLES = tuple(
    r
    for r in Role
    if r not in (Role.NONE, Role.SKIRT, Role.SUPPORT, Role.SUPPORT_INTERFACE, Role.WIPE_TOWER, Role.CUSTOM)
)
"""Roles whose material belongs to the part (perimeters, every infill, gap fill, ironing, ...)."""


@dataclass(frozen=True)
class Deposits:
    """Straight beads of material.

    Attributes
    ----------
    start, end : (n, 2) float, mm
        Centre line of each bead.
    z0 : (n,) float, mm
        Bottom of the bead's layer.
    height : (n,) float, mm
        Layer (bead) height.
    volume : (n,) float, mm³
        Material in the bead.
    layer : (n,) int
        Layer index (``Program.layers``), for grouping into plies.
    role : (n,) int
        :class:`~loadpath.gcode.flavors.Role` of each bead (``Role.SOLID_INFILL`` for engine paths).
    """

    start: Points2
    end: Points2
    z0: Floats
    height: Floats
    volume: Floats
    layer: Ints
    role: Ints

    def __post_init__(self) -> None:
        n = len(self.start)
        for name in ("end", "z0", "height", "volume", "layer", "role"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"Deposits.{name} has {len(getattr(self, name))} rows, start has {n}")

    def __len__(self) -> int:
        return len(self.start)

    @property
    def length(self) -> Floats:
        """Bead lengths, ``(n,)`` mm."""
        return np.hypot(*(self.end - self.start).T)

    @property
    def angle(self) -> Floats:
        """Direction of each bead, ``(n,)`` rad in ``(-pi, pi]`` (only modulo pi matters)."""
        d = self.end - self.start
        return np.arctan2(d[:, 1], d[:, 0])

    @property
    def flow_width(self) -> Floats:
        """``volume / (length * height)``, ``(n,)`` mm."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.volume / (self.length * self.height)

    @property
    def total_volume(self) -> float:
        """Sum of the volumes, mm³."""
        return float(np.sum(self.volume))

    def select(self, mask: np.ndarray | slice) -> Deposits:
        """Return the beads where ``mask`` is true (or those of a slice: views, not copies)."""
        m = mask if isinstance(mask, slice) else np.asarray(mask)
        return Deposits(
            self.start[m],
            self.end[m],
            self.z0[m],
            self.height[m],
            self.volume[m],
            self.layer[m],
            self.role[m],
        )

    @staticmethod
    def concat(parts: Iterable[Deposits]) -> Deposits:
        """All beads of several sets, in order."""
        ps = list(parts)
        if not ps:
            return _empty()
        return Deposits(
            *(
                np.concatenate([getattr(p, f) for p in ps])
                for f in ("start", "end", "z0", "height", "volume", "layer", "role")
            )
        )


@dataclass(frozen=True)
class Stack:
    """Deposits in print order as a sequence of parts, each a :class:`Deposits` or a function that
    makes one when it is read: a part's beads without all of them in memory at once.

    The bead model reads it a few layers at a time (:mod:`loadpath.stiffness.layered`).  The beads
    are those of :meth:`concat`.
    """

    parts: tuple

    def __len__(self) -> int:
        return len(self.parts)

    def part(self, i: int) -> Deposits:
        """Part ``i``, made if it is a function."""
        p = self.parts[i]
        return p if isinstance(p, Deposits) else p()

    def __iter__(self):  # type: ignore[no-untyped-def]
        return (self.part(i) for i in range(len(self.parts)))

    def concat(self) -> Deposits:
        """Every bead in one :class:`Deposits`."""
        return Deposits.concat(iter(self))


def _empty() -> Deposits:
    z = np.zeros(0)
    return Deposits(
        np.zeros((0, 2)), np.zeros((0, 2)), z, z, z, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    )


def from_program(
    program: Program,
    object_code: int | None = None,
    filament_diameter: float | None = None,
    roles: Sequence[Role] = PART_ROLES,
    exclude_blocks: Iterable[int] = (),
) -> Deposits:
    """Return the extrusions of one object of a G-code file.

    Parameters
    ----------
    program : Program
    object_code : int, optional
        Index into ``program.objects`` (``-1``: moves outside any object label); default every move.
    filament_diameter : float, mm, optional
        Default: :func:`loadpath.geometry.filament_diameter` (the configuration, else measured from
        the wall spacing).
    roles : sequence of Role
        Roles that count (default :data:`PART_ROLES`: not skirt, supports, wipe tower, purge lines).
    exclude_blocks : iterable of int
        Rows of ``program.blocks`` left out (blocks about to be replaced by new paths).

    Returns
    -------
    Deposits
        ``volume = e * pi D² / 4`` (``e`` in mm of filament, volumetric E already converted by the
        parser); ``z0 = z - height`` of the move.

    Raises
    ------
    GeometryError
        Nothing is extruded for this object.
    """
    from loadpath.geometry import filament_diameter as _diameter

    m = program.moves
    if filament_diameter is None:
        found = _diameter(program)  # (diameter, where it came from)
        d = float(found[0] if isinstance(found, tuple) else found)
    else:
        d = float(filament_diameter)
    keep = m["extrude"] & (m["layer"] >= 0) & np.isin(m["role"], np.asarray(roles, dtype=np.int64))
    keep &= (m["height"] > 0) & np.isfinite(m["height"]) & (m["e"] > 0)
    if object_code is not None:
        keep &= m["object"] == object_code
    for b in exclude_blocks:
        row = program.blocks[int(b)]
        keep[int(row["move_start"]) : int(row["move_stop"])] = False
    r = np.flatnonzero(keep)
    start = np.column_stack([m["x0"][r], m["y0"][r]])
    end = np.column_stack([m["x1"][r], m["y1"][r]])
    nonzero = np.hypot(*(end - start).T) > 0
    r, start, end = r[nonzero], start[nonzero], end[nonzero]
    if len(r) == 0:
        what = "the file" if object_code is None else f"object {object_code}"
        raise GeometryError(f"{what} extrudes nothing inside any layer; is this a sliced part?")
    h = m["height"][r]
    vol = m["e"][r] * (np.pi * d * d / 4.0)
    return Deposits(
        start,
        end,
        m["z1"][r] - h,
        h.astype(float),
        vol,
        m["layer"][r].astype(np.int64),
        m["role"][r].astype(np.int64),
    )


def from_toolpaths(
    paths: Toolpaths | Sequence[Path],
    z_top: float,
    height: float,
    layer: int,
    role: Role = Role.SOLID_INFILL,
) -> Deposits:
    """Turn an engine's paths into beads whose flow width is the local pitch (what the splicer extrudes).

    Parameters
    ----------
    paths : Toolpaths or sequence of Path
    z_top : float, mm
        Print z of the layer (its top).
    height : float, mm
        Layer height.
    layer : int
        Layer index the paths belong to.
    role : Role

    Returns
    -------
    Deposits
        One bead per path segment, ``volume = mean pitch of its ends * height * length``.
    """
    ps = paths.paths if isinstance(paths, Toolpaths) else tuple(paths)
    if not ps:
        return _empty()
    a = np.concatenate([p.points[:-1] for p in ps])
    b = np.concatenate([p.points[1:] for p in ps])
    w = np.concatenate([0.5 * (p.pitch[:-1] + p.pitch[1:]) for p in ps])
    length = np.hypot(*(b - a).T)
    ok = length > 0
    a, b, w, length = a[ok], b[ok], w[ok], length[ok]
    n = len(a)
    if not np.all(w > 0):
        raise GeometryError(
            f"layer {layer}: engine paths carry a non-positive local pitch; the flow width must be positive"
        )
    return Deposits(
        a,
        b,
        np.full(n, z_top - height),
        np.full(n, float(height)),
        w * height * length,
        np.full(n, int(layer), dtype=np.int64),
        np.full(n, int(role), dtype=np.int64),
    )
