"""Meshing: part outlines, prism stacks and STL models -> :class:`MeshData` (gmsh, headless).

Only :mod:`loadpath.mesh.gmsh_mesher` imports gmsh, and only when a mesh is made.
"""

from loadpath.mesh.data import CELL_TYPES, MeshData
from loadpath.mesh.sizing import (
    DEFAULT_MAX_TETS,
    DEFAULT_PITCH,
    MeshSize,
    default_mesh_size,
    reentrant_corners,
)

__all__ = [
    "MeshData",
    "CELL_TYPES",
    "MeshSize",
    "default_mesh_size",
    "reentrant_corners",
    "DEFAULT_PITCH",
    "DEFAULT_MAX_TETS",
    "mesh_2d",
    "mesh_3d",
    "mesh_stl",
]


def __getattr__(name: str):  # type: ignore[no-untyped-def]
    # the gmsh adapter (and gmsh itself) is imported on first use only
    if name in ("mesh_2d", "mesh_stl"):
        from loadpath.mesh import gmsh_mesher

        return getattr(gmsh_mesher, name)
    if name == "mesh_3d":
        from loadpath.mesh import layered

        return layered.mesh_3d
    raise AttributeError(f"module 'loadpath.mesh' has no attribute {name!r}")
