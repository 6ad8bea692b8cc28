"""The layer geometry as data: blocks in islands in layers in objects in a print.

Built by :func:`loadpath.geometry.layer_geometry`; every class is frozen.  Regions are shapely
Polygons or MultiPolygons in bed coordinates, mm; the empty region is an empty Polygon.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import shapely
from loadpath._typing import Region
from loadpath.areal import EMPTY, as_region
from loadpath.gcode.flavors import Dialect, Role
from loadpath.geometry.classify import DEFAULT_REPLACE, REPLACEABLE
from loadpath.geometry.ops import clean

if TYPE_CHECKING:  # the load case is optional here: imported when a body is asked for
    from loadpath.body import Body

__all__ = ["InfillBlock", "Island", "LayerGeometry", "ObjectGeometry", "PrintGeometry"]


@dataclass(frozen=True)
class InfillBlock:
    """One feature block of the G-code inside one island's infill domain.

    Attributes
    ----------
    block_index : int
        Row of ``Program.blocks`` (the lines a splicer replaces).
    feature : str
        The slicer's name (``"Solid infill"``, ``"SKIN"``, ``"FILL"``).
    role : Role
    kind : str
        What it is (:mod:`loadpath.geometry.classify`): ``"solid"``, ``"sparse"``, ``"top"``,
        ``"bottom"``, ``"bridge"``, ``"gap_fill"``, ``"ironing"`` or ``"other"``.
    region : Polygon or MultiPolygon
        The part of the domain the block fills: the domain minus the other blocks' footprints.
    footprint : Polygon or MultiPolygon
        The area its beads cover, closed over its pitch, within the domain.
    flow_width : float, mm
        Extruded cross-section / layer height, over the whole block.
    bead_width : float, mm
        The slicer's nominal width (``;WIDTH:``), the flow width when the file has none (Cura).
    height : float, mm
        Layer (bead) height.
    pitch : float, mm
        Line spacing the slicer used (dominant direction; ``area / length`` for curved patterns).
    angle : float, degrees
        Direction of its dominant lines in [0, 180), NaN for curved patterns.
    density : float
        Share of the region its beads cover (about 1 for solid infill).
    length : float, mm
        Extruded length inside this island.
    share : float
        Share of the block's extruded length inside this island (1 unless the slicer printed several
        islands in one block).
    exposed_down, exposed_up : float
        Shares of the region not supported by the layer below / not covered by the layer above.
    outside : float, mm
        Largest distance of the block's centre lines outside its region (checked against
        ``TOL.region_check_rel * flow_width``).
    """

    block_index: int
    feature: str
    role: Role
    kind: str
    region: Region = field(repr=False)
    footprint: Region = field(repr=False)
    flow_width: float
    bead_width: float
    height: float
    pitch: float
    angle: float
    density: float
    length: float
    share: float = 1.0
    exposed_down: float = 0.0
    exposed_up: float = 0.0
    outside: float = 0.0

    @property
    def replaceable(self) -> bool:
        """The kind is one the ``replace`` option can name."""
        return self.kind in REPLACEABLE


@dataclass(frozen=True)
class Island:
    """One connected piece of a layer of one object.

    Attributes
    ----------
    index : int
        Position in its layer (islands sorted by their lower-left corner).
    outline : Polygon
        Part outline: the outside of the external perimeter (what the FEA meshes).
    domain : Polygon or MultiPolygon
        Infill domain: inside the innermost perimeter (may be empty).
    blocks : tuple of InfillBlock
    """

    index: int
    outline: Region = field(repr=False)
    domain: Region = field(repr=False)
    blocks: tuple[InfillBlock, ...] = ()

    def replace_region(self, kinds: Iterable[str] = DEFAULT_REPLACE) -> Region:
        """Return the domain minus the footprints of the blocks that are kept.

        Parameters
        ----------
        kinds : iterable of str
            Kinds replaced (``"solid"``, ``"sparse"``, ``"top"``, ``"bottom"``).

        Returns
        -------
        Polygon or MultiPolygon
            Empty when no block of these kinds is in the island.
        """
        kinds = set(kinds)
        if not any(b.kind in kinds for b in self.blocks):
            return EMPTY
        drop = [b.footprint for b in self.blocks if b.kind not in kinds and not b.footprint.is_empty]
        if not drop:
            return self.domain
        return clean(shapely.difference(self.domain, shapely.union_all(drop)))

    def replaced(self, kinds: Iterable[str] = DEFAULT_REPLACE) -> tuple[InfillBlock, ...]:
        """Return the blocks of these kinds."""
        kinds = set(kinds)
        return tuple(b for b in self.blocks if b.kind in kinds)


@dataclass(frozen=True)
class LayerGeometry:
    """One layer of one object.

    Attributes
    ----------
    layer_index : int
        Index into ``Program.layers``.
    z : float, mm
        Top of the layer (print z).
    height : float, mm
        Layer height of this object here (bottom = ``z - height``).
    object : str
        The object's name (:attr:`ObjectGeometry.name`).
    islands : tuple of Island
    """

    layer_index: int
    z: float
    height: float
    object: str
    islands: tuple[Island, ...] = ()

    @property
    def z_bottom(self) -> float:
        """Bottom of the layer, mm."""
        return self.z - self.height

    @property
    def outline(self) -> Region:
        """Part outline of the whole layer (all islands)."""
        return as_region(shapely.union_all([i.outline for i in self.islands])) if self.islands else EMPTY

    @property
    def domain(self) -> Region:
        """Infill domain of the whole layer."""
        parts = [i.domain for i in self.islands if not i.domain.is_empty]
        return as_region(shapely.union_all(parts)) if parts else EMPTY

    @property
    def blocks(self) -> tuple[InfillBlock, ...]:
        """Every block of every island."""
        return tuple(b for i in self.islands for b in i.blocks)

    @property
    def kinds(self) -> tuple[str, ...]:
        """Kinds of the blocks present, sorted."""
        return tuple(sorted({b.kind for b in self.blocks}))

    def replace_region(self, kinds: Iterable[str] = DEFAULT_REPLACE) -> Region:
        """Union of the islands' replace regions."""
        kinds = tuple(kinds)
        parts = [r for i in self.islands if not (r := i.replace_region(kinds)).is_empty]
        return as_region(shapely.union_all(parts)) if parts else EMPTY


@dataclass(frozen=True)
class ObjectGeometry:
    """One object of the print, layer by layer.

    Attributes
    ----------
    name : str
        Short name (``"bracket.stl"``; the label without PrusaSlicer's `` id:N copy M`` suffix or
        Cura's folder), unique in the print; ``"part"`` when the file has no object labels.
    label : str
        The label as written in the G-code (``""`` without labels).
    code : int
        Index into ``Program.objects`` (-1: no label).
    layers : tuple of LayerGeometry
        The layers the object has perimeters in, bottom first.
    """

    name: str
    label: str
    code: int
    layers: tuple[LayerGeometry, ...]

    def layer_stack(self) -> list[tuple[float, float, Region]]:
        """``[(z_bottom, z_top, part_outline)]`` per layer: the input of ``Body.from_layers``."""
        return [(g.z_bottom, g.z, g.outline) for g in self.layers]

    def body(self) -> Body:
        """Return the object as a :class:`loadpath.body.Body` (one slab per layer, not merged)."""
        from loadpath.body import Body

        return Body.from_layers(self.name, self.layer_stack())


@dataclass(frozen=True)
class PrintGeometry:
    """The layer geometry of a whole G-code file.

    Attributes
    ----------
    objects : tuple of ObjectGeometry
    dialect : Dialect
    n_layers : int
        Layers in the file.
    filament_diameter : float, mm
        Used to turn E into flow widths.
    filament_source : str
        Where it came from: ``"config"``, ``"wall spacing"`` (measured) or ``"default"`` (1.75 mm).
    """

    objects: tuple[ObjectGeometry, ...]
    dialect: Dialect
    n_layers: int
    filament_diameter: float
    filament_source: str = "config"

    def object(self, name: str) -> ObjectGeometry:
        """Return the object with this name or label (KeyError listing the names otherwise)."""
        for o in self.objects:
            if name in (o.name, o.label):
                return o
        raise KeyError(f"no object {name!r}; objects: {', '.join(o.name for o in self.objects)}")

    def at(self, layer_index: int) -> list[LayerGeometry]:
        """Every object's geometry in one layer of the file."""
        return [g for o in self.objects for g in o.layers if g.layer_index == layer_index]

    def bodies(self, names: Sequence[str] | None = None) -> list[Body]:
        """:class:`loadpath.body.Body` of each object (or of the named ones), for ``resolve``."""
        objs = self.objects if names is None else [self.object(n) for n in names]
        return [o.body() for o in objs]
