"""The load case: TOML file -> validated data -> selections on the bodies of a print.

``read(path)`` / ``parse(text)`` give a :class:`LoadCase`; ``resolve(loadcase, bodies)`` applies it
to :class:`Body` stacks of slabs and gives one :class:`ResolvedBody` per body, ready for
``loadpath.fea``.
"""

from loadpath.body import Body, Slab, merge_slabs, outline_difference
from loadpath.loadcase.model import (
    PLA,
    BoxSelector,
    HoleSelector,
    Load,
    LoadCase,
    Material,
    Selector,
    SideSelector,
    Support,
    ToolpathOptions,
)
from loadpath.loadcase.parse import from_dict, parse, read
from loadpath.loadcase.resolve import ResolvedBody, resolve, resolve_body
from loadpath.loadcase.select import Selection, exposed_faces, select

__all__ = [
    "read",
    "parse",
    "from_dict",
    "resolve",
    "resolve_body",
    "LoadCase",
    "Material",
    "PLA",
    "Selector",
    "SideSelector",
    "BoxSelector",
    "HoleSelector",
    "Support",
    "Load",
    "ToolpathOptions",
    "Body",
    "Slab",
    "merge_slabs",
    "outline_difference",
    "Selection",
    "select",
    "exposed_faces",
    "ResolvedBody",
]
