"""Layer geometry from real slicer G-code: part outline, infill domain and infill blocks per island.

Typical use::

    from loadpath import gcode, geometry

    program = gcode.read("part.gcode")
    geo = geometry.layer_geometry(program)          # PrintGeometry
    for obj in geo.objects:                          # one per object on the bed
        for layer in obj.layers:                     # LayerGeometry (layer_index, z, height, islands)
            for island in layer.islands:             # Island (outline, domain, blocks)
                region = island.replace_region(["solid"])
                for block in island.replaced(["solid"]):
                    block.block_index, block.pitch, block.flow_width
    bodies = geo.bodies()                            # loadpath.loadcase.Body per object, for resolve()
    groups = geometry.distinct_layers(geo.objects[0], key="outline")   # solve / path once per group

Words (interface.md): **part outline** = the outside of the external perimeter (its centre line grown
by half its bead width); **infill domain** = inside the innermost perimeter; a block's **region** =
the domain minus the other blocks' footprints; **replace region** = the domain minus the footprints
of the blocks that are kept.  Kinds (:mod:`.classify`): ``solid`` (internal solid), ``sparse``,
``top``, ``bottom`` (the ``replace`` options), and ``bridge``, ``gap_fill``, ``ironing``, ``other``
(always kept).
"""

from loadpath.geometry.classify import DEFAULT_REPLACE, KINDS, REPLACEABLE, classify, exposed_fraction
from loadpath.geometry.flow import filament_diameter, flow_widths, wall_spacing
from loadpath.geometry.groups import LayerGroup, distinct_layers, group_regions
from loadpath.geometry.layers import layer_geometry, object_names
from loadpath.geometry.model import InfillBlock, Island, LayerGeometry, ObjectGeometry, PrintGeometry
from loadpath.geometry.ops import region_difference
from loadpath.geometry.pitch import PitchEstimate, estimate_pitch

__all__ = [
    "layer_geometry",
    "PrintGeometry",
    "ObjectGeometry",
    "LayerGeometry",
    "Island",
    "InfillBlock",
    "KINDS",
    "REPLACEABLE",
    "DEFAULT_REPLACE",
    "classify",
    "exposed_fraction",
    "estimate_pitch",
    "PitchEstimate",
    "distinct_layers",
    "group_regions",
    "LayerGroup",
    "region_difference",
    "filament_diameter",
    "flow_widths",
    "wall_spacing",
    "object_names",
]
