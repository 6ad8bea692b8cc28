"""What an infill block is: sparse, internal solid, top skin, bottom skin, or something kept.

Slicers name infill inconsistently (``../shared/docs/slicer-conventions.md`` §3.2): Cura writes 100 %
infill as ``FILL`` and every skin as ``SKIN``; PrusaSlicer writes bottom skins as ``Solid infill`` and
100 % sparse infill as ``Internal infill``.  So a block is classified by what it is:

1. Not infill: ``gap_fill``, ``ironing``, ``bridge`` (bridges are over air by construction), ``other``.
2. The object's first layer: ``bottom`` (it lies on the bed).
3. Sparse or solid by **density**, the share of its region its beads cover,
   ``sum(length * flow_width) / area(region)``: solid from :data:`SOLID_DENSITY` up, and a block the
   slicer printed as sparse infill from :data:`SPARSE_SOLID_DENSITY` up.  (When the region is too
   small to measure, the slicer's role decides.)
4. A solid block is a skin by **exposure**: ``bottom`` when at least :data:`EXPOSED` of its region is
   not supported by the layer below (outside that layer's part outline), ``top`` when at least
   :data:`EXPOSED` of it is not covered by the layer above (the object's last layer is all exposed).
   Exposed strips thinner than a bead (a tapered wall moving in by a fraction of a bead per layer)
   do not count.  The slicer's own top/bottom names (``Top solid infill``, ``Top surface``, ``Bottom
   surface``) are exposed skins by construction and are kept as such.

The kinds map onto the ``replace`` options of interface.md: ``"solid"`` (internal solid, replaced by
default), ``"sparse"``, ``"top"``, ``"bottom"``; every other kind is always kept.
"""

from __future__ import annotations

import math

import shapely
from loadpath._typing import Region
from loadpath.gcode.flavors import Role
from loadpath.geometry.ops import opening

__all__ = [
    "KINDS",
    "REPLACEABLE",
    "DEFAULT_REPLACE",
    "SOLID_DENSITY",
    "SPARSE_SOLID_DENSITY",
    "EXPOSED",
    "classify",
    "exposed_fraction",
]

KINDS = ("solid", "sparse", "top", "bottom", "bridge", "gap_fill", "ironing", "other")
"""Every kind a block can have."""

REPLACEABLE = ("solid", "sparse", "top", "bottom")
"""Kinds the ``replace`` option of a load case may name (interface.md)."""

DEFAULT_REPLACE = ("solid",)
"""What is replaced when the user says nothing: internal solid infill."""

SOLID_DENSITY = 0.7
"""A block whose beads cover at least this share of its region is solid (sparse infill of even 50 %
covers half; 100 % infill covers 0.95-1.05 depending on how the slicer rounds the line count)."""

SPARSE_SOLID_DENSITY = 0.9
"""The same for a block the slicer printed as sparse infill (Cura's ``FILL``, PrusaSlicer's ``Internal
infill``).  Such blocks cover what the slicer's density says: 0.71 at 70 %, 0.76 at 75 %, 0.96-0.97
at 95 %, 0.99 at 99 % (PrusaSlicer 2.5 and CuraEngine 4.13, 2026-12-07), and at 100 % 1.00-1.18 on
every one of 40 files of 22 parts.  A block taken as solid is laid at the solid pitch, so at 70 % its
new paths asked for 1 / 0.7 of the slicer's plastic, more than volume matching takes back
(``max_correction``, 15 %): every such block was kept as sliced, with a warning that blamed the engine,
and the default (internal solid only) had touched a part the user sliced sparse.  From 0.9 up the
correction is at most 11 %."""

EXPOSED = 0.1
"""Share of a solid block's region that must be exposed (below or above) for it to be a skin.  Low on
purpose: a block that is partly a visible surface is kept unless the user opts in."""


def exposed_fraction(region: Region, cover: Region | None, width: float) -> float:
    """Share of ``region`` outside ``cover``, ignoring strips thinner than one bead.

    Parameters
    ----------
    region : Polygon or MultiPolygon
        A block's region.
    cover : Polygon or MultiPolygon or None
        Part outline of the neighbouring layer (None: there is no layer there, all exposed).
    width : float, mm
        Bead width: exposed strips thinner than this are dropped (opening by half of it).
    """
    area = region.area
    if area <= 0:
        return 0.0
    if cover is None or cover.is_empty:
        return 1.0
    bare = opening(shapely.difference(region, cover), width / 2)
    return float(min(1.0, bare.area / area))


def classify(role: Role, density: float, first_layer: bool, exposed_down: float, exposed_up: float) -> str:
    """Return the kind of one block (see the module docstring).

    Parameters
    ----------
    role : Role
        The slicer's feature, as a role.
    density : float
        Covered share of the block's region (NaN when the region is too small to measure).
    first_layer : bool
        The block is in its object's first layer.
    exposed_down, exposed_up : float
        Shares of the region not supported below / not covered above (:func:`exposed_fraction`).

    Returns
    -------
    str
        One of :data:`KINDS`.
    """
    if role == Role.GAP_FILL:
        return "gap_fill"
    if role == Role.IRONING:
        return "ironing"
    if role == Role.BRIDGE_INFILL:
        return "bridge"
    if not role.is_infill:
        return "other"
    if first_layer or role == Role.BOTTOM_SOLID_INFILL:
        return "bottom"
    if role == Role.TOP_SOLID_INFILL:
        return "top"
    if math.isfinite(density):
        solid = density >= (SPARSE_SOLID_DENSITY if role == Role.SPARSE_INFILL else SOLID_DENSITY)
    else:
        solid = role != Role.SPARSE_INFILL
    if not solid:
        return "sparse"
    if exposed_down >= EXPOSED:
        return "bottom"
    if exposed_up >= EXPOSED:
        return "top"
    return "solid"
