"""The bead model's sampling of one batch of bead pieces onto a 2D mesh, in one compiled loop.

:func:`loadpath.stiffness.layered.sample_beads` places sample points along and across every bead
piece (:func:`loadpath.stiffness.fields._samples`), finds each point's element
(:class:`loadpath.fea.locate.TriangleLocator`) and adds the point's volume, direction harmonics and
attributes to its ply's and element's sums (:func:`loadpath.stiffness.fields.accumulate`).  In numpy
that builds a dozen arrays per sample point (about 8 million points per prediction of the shipped
example): 2.2 s of a 3.9 s prediction pair under cProfile, the point location alone being compiled
already.  :func:`sample_batch` does the same in one pass, point by point in the same order (width
classes ascending, then pieces, then along, then across), with the same arithmetic, and sums
each batch from zero before it is added, as ``np.bincount`` does: the sums are bit-identical.  The
volume of the points outside the mesh is returned point by point and summed by numpy, as before.

A sample point is first tested against the element of the point before it (:data:`HINT`), which
holds it most of the time (the points step 0.1 mm along and across a piece; the elements are
millimetres wide), and goes through its grid cell's candidates only when that fails: the same
element for every point, so the same sums bit for bit.  The shipped example's prediction pair (12
batches, one core): 3.04 -> 0.43-0.72 s; the verdict's stage of its first run 3.9 -> 2.0-2.7 s
(in process, two workers, another job on the cores).

Compiled with the engines' ``njit`` (:mod:`loadpath.engines.finish._numba`, stamped with this file
and the point location's).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from loadpath.jit import jit_family
from loadpath.fea import locate_kernel
from loadpath.fea.locate_kernel import barycentric, find, grid_arrays
from loadpath.stiffness.fields import bead_grid

__all__ = ["sample_batch"]

_njit, _ = jit_family((Path(__file__).resolve(), Path(locate_kernel.__file__).resolve()))

HINT = 1e-6
"""A point whose barycentric coordinates in the element of the point before all exceed this lies in
that element and in no other: :func:`~loadpath.fea.locate_kernel.find` accepts an element down to
``-eps`` (1e-9), and a neighbour across an edge sees the point at ``-d / h'`` where the element sees
``d / h``, so the two agree unless the neighbour is 1000 times taller.  Such points skip the grid
cell's candidates; the others are located as before, and every point gets the element it got
before."""


@_njit
def _batch(  # noqa: PLR0913
    rows, classes, ax, ay, dx, dy, length, width, n_al, n_ac, volume, cell_base, harm, attrs,
    ox, oy, step, nx, ny, start, cand, x0, y0, m00, m01, m10, m11, eps,
    vol, mom, acc, outside,
):
    bary = np.zeros(3)
    n_out = 0
    last = -1  # the element of the point before: the next one along or across a piece is mostly in it
    for nac in classes:
        for r in range(rows.shape[0]):
            s = rows[r]
            if n_ac[r] != nac:
                continue
            nal = n_al[r]
            u0 = dx[r] / length[r]
            u1 = dy[r] / length[r]
            nx0 = -u1 * width[r]
            ny0 = u0 * width[r]
            share = volume[r] / (nal * nac * 1)
            base = cell_base[r]
            for k in range(nal):
                t = (k + 0.5) / nal
                cx = ax[r] + t * dx[r]
                cy = ay[r] + t * dy[r]
                for j in range(nac):
                    off = (j + 0.5) / nac - 0.5
                    px = cx + off * nx0
                    py = cy + off * ny0
                    e = -1
                    if last >= 0:  # inside it by more than HINT: no other element's test passes
                        l0, l1, l2 = barycentric(px, py, last, x0, y0, m00, m01, m10, m11)
                        if l0 > HINT and l1 > HINT and l2 > HINT:
                            e = last
                    if e < 0:
                        e = find(
                            px, py, ox, oy, step, nx, ny, start, cand, x0, y0, m00, m01, m10, m11, eps, bary
                        )
                    if e < 0:
                        outside[n_out] = share
                        n_out += 1
                        continue
                    last = e
                    i = base + e
                    vol[i] += share
                    for h in range(4):
                        mom[i, h] += share * harm[s, h]
                    for a in range(attrs.shape[0]):
                        acc[a, i] += share * attrs[a, s]
    return n_out


def sample_batch(
    pieces, part: np.ndarray, resolution: float, locator, cell_base: np.ndarray, harm: np.ndarray,
    attrs: np.ndarray, n_cells: int, eps: float = 1e-9,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Sums of one batch of bead pieces' sample points per cell, and the volume outside the mesh.

    Parameters
    ----------
    pieces : Deposits
        The chunk's bead pieces.
    part : (b,) int
        The batch: rows of ``pieces``, ascending.
    resolution : float, mm
        Distance between sample points along and across a piece.
    locator : TriangleLocator
        Of the mesh's elements.
    cell_base : (b,) int
        Each piece's first cell: ``ply * m`` (its ply in the chunk times the number of elements).
    harm : (n, 4) float
        Direction harmonics per piece (``fields._harmonics``).
    attrs : (a, n) float
        Per-piece attributes to average (``width``, ``fused``, ``transfer``).
    n_cells : int
        Cells of the chunk (plies x elements).
    eps : float
        The locator's barycentric tolerance.

    Returns
    -------
    vol : (n_cells,) float, mm³
    mom : (n_cells, 4) float
        Volume-weighted harmonics.
    acc : (a, n_cells) float
        Volume-weighted attributes.
    lost : float, mm³
        Volume of the sample points outside every element.
    """
    a, d, length, w, n_al, n_ac = bead_grid(pieces, part, resolution)
    vol = np.zeros(n_cells)
    mom = np.zeros((n_cells, 4))
    acc = np.zeros((len(attrs), n_cells))
    outside = np.empty(int(np.sum(n_al * n_ac)))
    col = np.ascontiguousarray
    n_out = _batch(
        col(part, dtype=np.int64), np.unique(n_ac), col(a[:, 0]), col(a[:, 1]), col(d[:, 0]), col(d[:, 1]),
        length, w, n_al, n_ac, col(pieces.volume[part], dtype=float), col(cell_base, dtype=np.int64),
        col(harm, dtype=float), col(attrs, dtype=float), *grid_arrays(locator), float(eps),
        vol, mom, acc, outside,
    )
    return vol, mom, acc, float(np.sum(outside[:n_out]))
