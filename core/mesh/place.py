"""Place an STL model where the slicer put it: match its footprint to the G-code's first layer.

Slicers move (and may rotate or scale) the model on the bed; the G-code keeps only the result. With
``--model part.stl`` the model is dropped onto the bed (lowest point at z = 0) and moved in x and y
so that the centroid of its footprint (its section at the middle of the first layer) falls on the
centroid of the G-code's first-layer part outline. If the two shapes still disagree (the part was
rotated or scaled in the slicer), placing is refused with a message suggesting an explicit transform.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import shapely
from loadpath._typing import Region
from loadpath.errors import GeometryError, MeshingError, ToolMissingError
from loadpath.body import outline_difference
from shapely.geometry import Polygon

__all__ = ["place_stl", "footprint"]


def _trimesh(path: str | Path):  # type: ignore[no-untyped-def]
    try:
        import trimesh
    except ImportError as exc:  # pragma: no cover
        raise ToolMissingError("reading STL models needs trimesh: pip install trimesh") from exc
    p = Path(path)
    if not p.is_file():
        raise MeshingError(f"STL file {str(p)!r} does not exist; check the --model path")
    mesh = trimesh.load(str(p), force="mesh")
    if mesh.is_empty or len(mesh.faces) == 0:
        raise MeshingError(f"STL file {p.name!r} has no triangles")
    if not mesh.is_watertight:
        raise MeshingError(
            f"STL model {p.name!r} is not closed (watertight); "
            "repair it (e.g. in the slicer) and export it again"
        )
    return mesh


def footprint(mesh, z: float) -> Region:  # type: ignore[no-untyped-def]
    """Section of a closed triangle mesh at height ``z`` as shapely polygons (xy).

    Every triangle the plane cuts gives one segment (a vertex exactly on the plane counts as
    above); :func:`shapely.build_area` turns the segments into polygons with holes.
    """
    V = np.asarray(mesh.vertices, dtype=float)
    F = np.asarray(mesh.faces, dtype=np.int64)
    s = V[F, 2] - z  # (f, 3)
    up = s >= 0
    n_up = up.sum(axis=1)
    cut = (n_up > 0) & (n_up < 3)
    F, s, up = F[cut], s[cut], up[cut]
    a = np.array([0, 1, 2])
    b = np.array([1, 2, 0])
    cross = up[:, a] != up[:, b]  # exactly two edges per cut triangle
    sa, sb = s[:, a], s[:, b]
    t = np.divide(sa, sa - sb, out=np.zeros_like(sa), where=cross)
    pa, pb = V[F[:, a], :2], V[F[:, b], :2]
    pts = pa + t[..., None] * (pb - pa)  # (f, 3, 2)
    ends = pts[cross].reshape(-1, 2, 2)
    if len(ends) == 0:
        return Polygon()
    return shapely.build_area(shapely.unary_union(shapely.linestrings(ends)))


def place_stl(
    path: str | Path,
    first_layer: Region,
    first_layer_height: float = 0.2,
    transform: np.ndarray | None = None,
    tol: float = 0.5,
) -> np.ndarray:
    """Return the transform that puts an STL model where the G-code has it.

    Parameters
    ----------
    path : str or Path
        The STL (mm).
    first_layer : shapely Polygon or MultiPolygon, mm
        The part outline of the G-code's first layer.
    first_layer_height : float, mm
        Its height; the model's footprint is taken at half of it.
    transform : (4, 4) float, optional
        An explicit placement (for rotated or scaled parts): used as given, and only checked.
    tol : float, mm
        Largest accepted mean distance between the placed footprint and the first layer
        (``area(a xor b) / perimeter``; an elephant-foot compensation of 0.2 mm gives about 0.2).

    Returns
    -------
    (4, 4) float
        Model coordinates -> bed coordinates.

    Raises
    ------
    GeometryError
        The footprint does not match the first layer.
    """
    mesh = _trimesh(path)
    if transform is None:
        T = np.eye(4)
        T[2, 3] = -float(mesh.bounds[0, 2])
    else:
        T = np.asarray(transform, dtype=float)
        if T.shape != (4, 4):
            raise ValueError(f"transform must be a 4 x 4 matrix, got shape {T.shape}")
    placed = mesh.copy()
    placed.apply_transform(T)
    foot = footprint(placed, float(placed.bounds[0, 2]) + 0.5 * first_layer_height)
    if foot.is_empty:
        raise GeometryError(
            f"STL model {Path(path).name!r} has no footprint at the first layer; is it a closed solid in mm?"
        )
    if transform is None:
        c, g = foot.centroid, first_layer.centroid
        T2 = np.eye(4)
        T2[0, 3], T2[1, 3] = g.x - c.x, g.y - c.y
        T = T2 @ T
        foot = shapely.affinity.translate(foot, g.x - c.x, g.y - c.y)
    d = outline_difference(first_layer, foot)
    if d > tol:
        fx0, fy0, fx1, fy1 = foot.bounds
        gx0, gy0, gx1, gy1 = first_layer.bounds
        raise GeometryError(
            f"STL model {Path(path).name!r} does not match the G-code's first layer: "
            f"footprint {fx1 - fx0:.1f} x {fy1 - fy0:.1f} mm "
            f"vs first layer {gx1 - gx0:.1f} x {gy1 - gy0:.1f} mm, mean distance {d:.2f} mm after placing; "
            "if the part was rotated or scaled in the slicer, "
            "give the transform explicitly (--model-transform)"
        )
    return T
