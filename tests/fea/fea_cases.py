"""Shared load cases for the FEA tests: the open-hole specimen (benchmarks.md §4) and a cantilever."""

from __future__ import annotations

import math

import numpy as np
import slicing
from cases import TOWER_PUSH
from loadpath.loadcase import Body, parse
from shapely.geometry import Point, box

W, L, T, D_HOLE, F = 36.0, 150.0, 2.0, 6.0, 1000.0
CENTRE = (75.0, 18.0)
SIGMA_GROSS = F / (W * T)
KT_HANDBOOK = 3.09  # Heywood 3.094, Peterson 3.087 (benchmarks.md §4)

OPEN_HOLE_CASE = """
version = 1
[material]
youngs_modulus = 3500.0
poissons_ratio = 0.35
[[supports]]
name = "clamp"
where = { side = "x_min", within = 0.5 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { side = "x_max", within = 0.5 }
force = [1000.0, 0.0, 0.0]
"""


def hole_segments(h: float) -> int:
    """Polygon sides of the hole so its edges are about ``h`` long (a multiple of 4, at least 32)."""
    return max(32, 4 * math.ceil(math.pi * D_HOLE / h / 4))


def open_hole_outline(n_seg: int = 128):
    """The 150 x 36 mm specimen with a 6 mm hole polygonised with ``n_seg`` sides (vertices on the axes)."""
    return box(0, 0, L, W).difference(Point(*CENTRE).buffer(D_HOLE / 2, quad_segs=n_seg // 4))


def open_hole_body(n_seg: int = 128, layers: int = 1) -> Body:
    dz = T / layers
    return Body.from_layers(
        "specimen", [(i * dz, (i + 1) * dz, open_hole_outline(n_seg)) for i in range(layers)]
    )


def open_hole_case(source: str = "open_hole.toml"):
    return parse(OPEN_HOLE_CASE, source)


def kt_at_hole(points: np.ndarray, stress: np.ndarray) -> float:
    """Largest nodal sxx on the hole edge over the gross stress F / (W t)."""
    p = np.asarray(points)
    on_hole = np.hypot(p[:, 0] - CENTRE[0], p[:, 1] - CENTRE[1]) < D_HOLE / 2 + 1e-3
    return float(np.max(stress[on_hole, 0]) / SIGMA_GROSS)


def rate(h: np.ndarray, err: np.ndarray) -> float:
    """Slope of the least-squares line through (log h, log err)."""
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


TOWER_CASE = TOWER_PUSH


def twisted_tower(n: int = 120, dz: float = 0.2, twist: float = 30.0, scale_top: float = 0.6) -> Body:
    """The test tower (``slicing.tower_mesh``) as a body of ``n`` layer outlines: 30 x 20 plate with an
    8 mm hole, twisted and tapered, so every layer's outline differs from the one below."""
    return Body.from_layers("tower", slicing.tower_layers(n, dz, twist, scale_top))
