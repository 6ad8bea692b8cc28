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

Compiled with the engines' ``njit`` (:mod:`loadpath.engines.finish._numba`, stamped with this file
and the point location's).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from loadpath.jit import jit_family
from loadpath.fea import locate_kernel
from loadpath.fea.locate_kernel import find, grid_arrays
from loadpath.stiffness.fields import bead_grid

__all__ = ["sample_batch"]

_njit, _ = jit_family((Path(__file__).resolve(), Path(locate_kernel.__file__).resolve()))


@_njit
def _batch(  # noqa: PLR0913
    rows, classes, ax, ay, dx, dy, length, width, n_al, n_ac, volume, cell_base, harm, attrs,
    ox, oy, step, nx, ny, start, cand, x0, y0, m00, m01, m10, m11, eps,
    vol, mom, acc, outside,
):
    bary = np.zeros(3)
    n_out = 0
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
                    e = find(px, py, ox, oy, step, nx, ny, start, cand, x0, y0, m00, m01, m10, m11, eps, bary)
                    if e < 0:
                        outside[n_out] = share
                        n_out += 1
                        continue
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
