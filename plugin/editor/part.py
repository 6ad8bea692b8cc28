"""The part the load-case editor shows: its bodies (stacks of outlines) from G-code or from an STL.

G-code: the part outline of each layer exactly as ``inspect`` and ``run`` derive it
(:func:`loadpath.geometry.layer_geometry`).  STL: cross-sections of the mesh (trimesh) at the middle
of each layer, for a load case made before slicing; its selectors are written with
``frame = "part"`` so the case fits wherever the slicer places the part.

What the page draws comes from :func:`layer_view`: per distinct region over the height (the slabs of
:func:`loadpath.loadcase.merge_slabs`), the outline, its holes and its straight edges, each with the
selector a click on it makes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from loadpath.areal import polygons_of
from loadpath.errors import LoadpathError
from loadpath.loadcase import Body, merge_slabs
from shapely.geometry import LineString, MultiLineString, Polygon

__all__ = [
    "EditorPart",
    "load_part",
    "section_stl",
    "layer_view",
    "frame_origin",
    "STL_LAYER_MM",
    "EDGE_PAD_MM",
]

STL_LAYER_MM = 0.2
"""Height step of the STL's cross-sections (a typical layer height)."""

_MAX_SECTIONS = 400
EDGE_PAD_MM = 0.5
"""How far beyond a clicked edge its box selector reaches (and a side selector's ``within``)."""

_CORNER_DEG = 25.0


@dataclass(frozen=True)
class EditorPart:
    """What the editor works on.

    Attributes
    ----------
    path : Path
    kind : {"gcode", "stl"}
    bodies : tuple of Body
        One per object, one slab per layer (G-code) or cross-section (STL).
    frame : {"bed", "part"}
        The frame a new load case is written in.
    program, geo : optional
        The parsed G-code and its layer geometry (None for an STL).
    """

    path: Path
    kind: str
    bodies: tuple[Body, ...]
    frame: str
    program: Any = None
    geo: Any = None

    @property
    def merged(self) -> tuple[Body, ...]:
        """The bodies merged into prisms (what selectors are evaluated on)."""
        return tuple(merge_slabs(b) for b in self.bodies)


def section_stl(path: Path, step: float = STL_LAYER_MM) -> Body:
    """Cross-sections of an STL at the middle of each layer of height ``step``.

    Parameters
    ----------
    path : Path
        STL (any mesh trimesh reads).
    step : float, mm
        Layer height; raised so at most 400 sections are taken.

    Returns
    -------
    Body
        Named after the file, one slab per section (z from the mesh's own coordinates).

    Raises
    ------
    LoadpathError
        Unreadable file, or no closed cross-section.
    """
    import trimesh

    try:
        mesh = trimesh.load(str(path), force="mesh")
    except (OSError, ValueError) as exc:
        raise LoadpathError(
            f"cannot read STL {str(path)!r}: {exc}; check the path and that it is a mesh"
        ) from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise LoadpathError(f"{path}: no triangles in the file; export the part as an STL mesh")
    z_lo, z_hi = (float(v) for v in mesh.bounds[:, 2])
    n = max(1, round((z_hi - z_lo) / step))
    if n > _MAX_SECTIONS:
        n = _MAX_SECTIONS
    dz = (z_hi - z_lo) / n
    heights = z_lo + dz * (np.arange(n) + 0.5)
    lines = trimesh.intersections.mesh_multiplane(mesh, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], heights)[0]
    layers = []
    for i, segs in enumerate(lines):
        region = _rings_to_region(np.asarray(segs)[:, :, :2])
        if region is None:
            raise LoadpathError(
                f"{path}: the cross-section at z = {heights[i]:.2f} mm is not closed; "
                "repair the mesh (it must be watertight)"
            )
        layers.append((z_lo + i * dz, z_lo + (i + 1) * dz, region))
    return Body.from_layers(path.name, layers)


def _rings_to_region(segs: np.ndarray) -> Any:
    """Join section segments into closed loops ``(m, 2, 2)``, nested by even-odd (holes inside outers)."""
    if len(segs) == 0:
        return None
    merged = shapely.line_merge(MultiLineString([LineString(s) for s in np.round(segs, 9)]))
    rings = [g for g in getattr(merged, "geoms", [merged]) if g.is_closed and len(g.coords) >= 4]
    if not rings:
        return None
    region = Polygon()
    for r in rings:
        region = shapely.symmetric_difference(region, shapely.make_valid(Polygon(r.coords)))
    region = shapely.unary_union([p for p in getattr(region, "geoms", [region]) if isinstance(p, Polygon)])
    return None if region.is_empty else region


def load_part(path: str | Path) -> EditorPart:
    """Read G-code (``.gcode``, ``.bgcode``, ...) or an STL / mesh file (``.stl``, ``.obj``, ``.3mf``)."""
    p = Path(path)
    if not p.is_file():
        raise LoadpathError(f"{str(p)!r} does not exist or is not a file; give a G-code or STL file")
    if p.suffix.lower() in (".stl", ".obj", ".ply", ".3mf", ".off"):
        return EditorPart(p, "stl", (section_stl(p),), "part")
    from loadpath import gcode, geometry

    program = gcode.read(p)
    geo = geometry.layer_geometry(program, check=False)
    bodies = tuple(geo.bodies())
    if not bodies:
        raise LoadpathError(f"{p}: no printed object with layer outlines was found; slice the part first")
    return EditorPart(p, "gcode", bodies, "bed", program, geo)


# ------------------------------------------------------------------------------- what the page draws


def _coords(g: Any) -> list[list[float]]:
    return np.round(np.asarray(g.coords)[:, :2], 4).tolist()


def _edges(ring: Any, tol: float) -> list[np.ndarray]:
    """Split a ring into straight runs at its corners (turns above 25 degrees)."""
    simple = shapely.simplify(LineString(ring.coords), tol)
    c = np.asarray(simple.coords)[:, :2]
    if len(c) < 3:
        return []
    c = c[:-1] if np.allclose(c[0], c[-1]) else c
    d = np.roll(c, -1, axis=0) - c
    ang = np.arctan2(d[:, 1], d[:, 0])
    turn = np.abs((np.roll(ang, -1) - ang + np.pi) % (2 * np.pi) - np.pi)
    corners = np.flatnonzero(turn > math.radians(_CORNER_DEG)) + 1  # vertex index starting a new edge
    if len(corners) == 0:
        return [np.vstack([c, c[:1]])]
    out = []
    for a, b in zip(corners, np.roll(corners, -1), strict=True):
        idx = np.arange(a, a + ((b - a) % len(c) or len(c)) + 1) % len(c)
        out.append(c[idx])
    return out


def _edge_selector(pts: np.ndarray, body: Body, origin: np.ndarray) -> dict[str, Any]:
    """Return the selector a click on an edge makes.

    A side selector when the edge lies on a side of the part's bounding box (it fits any placement),
    else the edge's box widened by 0.5 mm.
    """
    lo, hi = body.bounds
    span = float(np.max(hi[:2] - lo[:2]))
    on = 1e-3 * span + 0.05
    for axis, a in enumerate("xy"):
        if np.all(np.abs(pts[:, axis] - lo[axis]) <= on):
            return {"side": f"{a}_min", "within": EDGE_PAD_MM}
        if np.all(np.abs(pts[:, axis] - hi[axis]) <= on):
            return {"side": f"{a}_max", "within": EDGE_PAD_MM}
    b0 = pts.min(axis=0) - EDGE_PAD_MM - origin[:2]
    b1 = pts.max(axis=0) + EDGE_PAD_MM - origin[:2]
    return {
        "x_min": round(float(b0[0]), 3),
        "x_max": round(float(b1[0]), 3),
        "y_min": round(float(b0[1]), 3),
        "y_max": round(float(b1[1]), 3),
    }


def frame_origin(body: Body, frame: str) -> np.ndarray:
    """Origin of selector coordinates: the merged body's minimum corner for ``frame = "part"``."""
    return merge_slabs(body).bounds[0] if frame == "part" else np.zeros(3)


def layer_view(part: EditorPart, frame: str) -> dict[str, Any]:
    """Everything the page draws of the part, JSON-ready.

    Returns
    -------
    dict
        ``bounds`` ([x0, y0, x1, y1] mm), ``objects`` (names, with their ``origin`` in the case's
        frame), and ``layers``: per distinct region over the height, ``z0``, ``z1``, ``z`` (middle),
        ``file_layers`` (G-code layer numbers, counted from 1), and per object its ``polygons``
        (exterior and holes as coordinate lists), ``holes`` (centre, diameter, ring and the hole
        selector a click makes) and ``edges`` (polyline and its selector).
    """
    merged = part.merged
    cuts = sorted({round(z, 6) for b in merged for s in b.slabs for z in (s.z0, s.z1)})
    lo = np.min([b.bounds[0] for b in merged], axis=0)
    hi = np.max([b.bounds[1] for b in merged], axis=0)
    span = float(np.max(hi[:2] - lo[:2]))
    origins = {b.name: frame_origin(b, frame) for b in part.bodies}
    layers = []
    for z0, z1 in zip(cuts[:-1], cuts[1:], strict=True):
        zm = 0.5 * (z0 + z1)
        objs = []
        for b in merged:
            slab = b.slab_at(zm)
            if slab is None or not (slab.z0 - 1e-6 <= zm <= slab.z1 + 1e-6):
                continue
            origin = origins[b.name]
            polys, holes, edges = [], [], []
            for poly in polygons_of(slab.outline):
                polys.append([_coords(poly.exterior)] + [_coords(r) for r in poly.interiors])
                for ring in poly.interiors:
                    hp = Polygon(ring)
                    c = np.asarray(hp.centroid.coords)[0]
                    d = 2.0 * math.sqrt(hp.area / math.pi)
                    holes.append(
                        {
                            "center": np.round(c, 4).tolist(),
                            "diameter": round(d, 3),
                            "ring": _coords(ring),
                            "where": {
                                "hole_near": [
                                    round(float(c[0] - origin[0]), 3),
                                    round(float(c[1] - origin[1]), 3),
                                ],
                                "radius": round(max(0.5, d / 4), 2),
                            },
                        }
                    )
                for ring in [poly.exterior]:
                    for e in _edges(ring, 0.002 * span):
                        edges.append(
                            {
                                "points": np.round(e, 4).tolist(),
                                "length": round(float(LineString(e).length), 3),
                                "where": _edge_selector(e, b, origin),
                            }
                        )
            objs.append({"name": b.name, "polygons": polys, "holes": holes, "edges": edges})
        file_layers = []
        if part.geo is not None:
            file_layers = sorted(
                {
                    g.layer_index + 1
                    for o in part.geo.objects
                    for g in o.layers
                    if z0 - 1e-6 <= g.z - g.height / 2 <= z1 + 1e-6
                }
            )
        layers.append({"z0": z0, "z1": z1, "z": zm, "file_layers": file_layers, "objects": objs})
    return {
        "bounds": [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])],
        "z_range": [float(lo[2]), float(hi[2])],
        "objects": [{"name": b.name, "origin": np.round(origins[b.name], 4).tolist()} for b in part.bodies],
        "layers": layers,
    }
