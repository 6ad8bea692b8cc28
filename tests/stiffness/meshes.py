"""Structured quadratic meshes of a rectangle (tri6) and a box (tet10), built without gmsh.

Corner nodes sit on a grid of even indices of a half-spacing grid, so the middle of every element
edge is a grid node too (the mid-edge nodes come for free and are shared).
"""

from __future__ import annotations

import itertools

import numpy as np
from loadpath.mesh.data import MeshData


def rectangle_tri6(length: float, width: float, nx: int, ny: int, thickness: float = 1.0) -> MeshData:
    """``nx x ny`` squares, two straight-sided tri6 each, over ``[0, length] x [0, width]``."""
    gx, gy = 2 * nx + 1, 2 * ny + 1
    xs, ys = np.linspace(0.0, length, gx), np.linspace(0.0, width, gy)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])

    def node(i, j):
        return i * gy + j

    cells = []
    for i in range(nx):
        for j in range(ny):
            a, b, c, d = (2 * i, 2 * j), (2 * i + 2, 2 * j), (2 * i + 2, 2 * j + 2), (2 * i, 2 * j + 2)
            for tri in ((a, b, c), (a, c, d)):
                corners = [node(*p) for p in tri]
                mids = [
                    node((tri[k][0] + tri[(k + 1) % 3][0]) // 2, (tri[k][1] + tri[(k + 1) % 3][1]) // 2)
                    for k in range(3)
                ]
                cells.append(corners + mids)
    cells = np.array(cells)
    used = np.unique(cells)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    return MeshData(pts[used], remap[cells], "tri6", thickness=thickness, z_range=(0.0, thickness))


_TET10_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]


def box_tet10(size: tuple[float, float, float], n: tuple[int, int, int]) -> MeshData:
    """Each of ``n`` cubes split into six tet10 (Kuhn), over ``[0, size]``."""
    g = [2 * k + 1 for k in n]
    axes = [np.linspace(0.0, s, k) for s, k in zip(size, g, strict=True)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])

    def node(p):
        return (p[0] * g[1] + p[1]) * g[2] + p[2]

    cells = []
    for i, j, k in itertools.product(*(range(m) for m in n)):
        o = np.array([2 * i, 2 * j, 2 * k])
        for perm in itertools.permutations(range(3)):
            v = [o.copy()]
            for ax in perm:
                nxt = v[-1].copy()
                nxt[ax] += 2
                v.append(nxt)
            P = np.array([pts[node(p)] for p in v])
            if np.linalg.det(np.array([P[1] - P[0], P[2] - P[0], P[3] - P[0]])) < 0:
                v[1], v[2] = v[2], v[1]
            corners = [node(p) for p in v]
            mids = [node((v[a] + v[b]) // 2) for a, b in _TET10_EDGES]
            cells.append(corners + mids)
    cells = np.array(cells)
    used = np.unique(cells)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    return MeshData(pts[used], remap[cells], "tet10")
