"""The compiled point location (:mod:`loadpath.fea.locate_kernel`) returns numpy's answers bit for bit.

:meth:`TriangleLocator.locate` switches to the compiled loop from ``COMPILED_FROM`` points; both
must give the same triangle (the first candidate of the cell that holds the point) and the same
barycentric coordinates, also for points on shared edges and corners (held by several triangles),
outside the mesh, in grid cells without triangles, and NaN.
"""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.fea import locate as loc
from loadpath.fea.locate import TriangleLocator


def _mesh(rng: np.random.Generator) -> np.ndarray:
    """A jittered grid of 20 x 12 squares split into two triangles each, a hole of 4 squares, (m, 3, 2)."""
    xs, ys = np.meshgrid(np.arange(21) * 1.5, np.arange(13) * 0.9, indexing="ij")
    p = np.stack([xs, ys], axis=-1) + rng.uniform(-0.2, 0.2, (21, 13, 2))
    tris = []
    for i in range(20):
        for j in range(12):
            if 8 <= i < 10 and 5 <= j < 7:
                continue
            a, b, c, d = p[i, j], p[i + 1, j], p[i + 1, j + 1], p[i, j + 1]
            tris += [(a, b, c), (a, c, d)]
    tris.append((p[0, 0], p[0, 0], p[1, 1]))  # degenerate: never found
    return np.array(tris)


def _points(corners: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    inside = rng.uniform([-2, -2], [32, 13], (40_000, 2))
    edges = corners[:, 0] + rng.uniform(0, 1, (len(corners), 1)) * (corners[:, 1] - corners[:, 0])
    vertices = corners.reshape(-1, 2)
    nan = np.full((3, 2), np.nan)
    return np.concatenate([inside, edges, vertices, nan])


@pytest.mark.parametrize("cell_factor", [1.0, 0.5, 3.0])
def test_compiled_equals_numpy(monkeypatch, cell_factor):
    rng = np.random.default_rng(7)
    corners = _mesh(rng)
    pts = _points(corners, rng)
    locator = TriangleLocator(corners, cell_factor=cell_factor)
    monkeypatch.setattr(loc, "COMPILED_FROM", len(pts) + 1)
    tri0, bary0 = locator.locate(pts)
    monkeypatch.setattr(loc, "COMPILED_FROM", 1)
    tri1, bary1 = locator.locate(pts)
    assert (tri0 >= 0).sum() > 20_000 and (tri0 < 0).sum() > 1_000  # both kinds of answer
    assert locator.max_candidates > 1  # cells with several candidates: the order matters
    np.testing.assert_array_equal(tri1, tri0)
    assert bary1.tobytes() == bary0.tobytes()


def test_compiled_used_for_large_queries(monkeypatch):
    """From ``COMPILED_FROM`` points the compiled loop answers (numpy's loop would raise here)."""
    from loadpath.fea import locate_kernel

    rng = np.random.default_rng(3)
    corners = _mesh(rng)
    locator = TriangleLocator(corners)
    calls = []
    real = locate_kernel.locate_points

    def spy(*args):
        calls.append(len(args[1]))
        return real(*args)

    monkeypatch.setattr(locate_kernel, "locate_points", spy)
    locator.locate(rng.uniform(0, 10, (loc.COMPILED_FROM - 1, 2)))
    assert calls == []
    locator.locate(rng.uniform(0, 10, (loc.COMPILED_FROM, 2)))
    assert calls == [loc.COMPILED_FROM]
