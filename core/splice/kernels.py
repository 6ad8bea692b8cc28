"""The splice's compiled loops, for large splices (:mod:`loadpath.splice.compiled` loads them).

:func:`rdp_keep`: the Ramer-Douglas-Peucker pass of :func:`loadpath.splice.plan.simplify_mask`.
The numpy pass splits every segment of every path one recursion level at a time, gathering the
inner vertices of all segments still being split into fresh arrays on each level: about 30 array
operations per vertex and level.  On the 1000-layer specimen's splice that was 4.0 s of its 16.5 s
of CPU (15 million vertices through two passes).  This loop takes each path's segments from a stack
with the same arithmetic in the same order (no ``fastmath``: no fused multiply-adds), so it keeps
the same vertices: a segment's split depends on its two ends alone, not on the order segments are
taken in.  Per segment, the worst vertex is the first one with the largest error, NaN errors
ignored (numpy's ``fmax.reduceat``), and an error is NaN when either of its terms is
(``np.maximum``).


:func:`run_index`: :func:`loadpath.splice.beadruns.runs_of_widths`, a pass that is sequential by
nature (each run's band of widths depends on where the one before ended), the same comparisons in
the same order: 1.5 s of the 1000-layer specimen's splice as a Python loop.

Compiled with the engines' ``njit`` (numba's on-disk cache, stamped with this file) and imported
only for large splices (:data:`loadpath.splice.compiled.COMPILED_FROM` vertices): a small file's
run never imports numba for them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from loadpath.jit import jit_family

__all__ = ["rdp_keep", "run_index"]

_njit, _ = jit_family((Path(__file__).resolve(),))


@_njit
def _rdp(px, py, pit, starts, ends, tol, pitch_tol, keep):  # pragma: no cover - compiled
    # the segments waiting on the stack split one path into disjoint pieces: at most its size
    size = 2
    for p in range(starts.shape[0]):
        size = max(size, ends[p] - starts[p] + 1)
    stack = np.zeros((size, 2), dtype=np.int64)
    for p in range(starts.shape[0]):
        stack[0, 0] = starts[p]
        stack[0, 1] = ends[p] - 1
        top = 1
        while top > 0:
            top -= 1
            a = stack[top, 0]
            z = stack[top, 1]
            if z - a <= 1:
                continue
            dx = px[z] - px[a]
            dy = py[z] - py[a]
            seg2 = dx * dx + dy * dy
            seg = np.sqrt(seg2)
            wa = pit[a]
            dw = pit[z] - pit[a]
            worst = np.nan
            m = -1
            for i in range(a + 1, z):
                rx = px[i] - px[a]
                ry = py[i] - py[a]
                if seg > 0:
                    dist = np.abs(rx * dy - ry * dx) / seg
                    t = (rx * dx + ry * dy) / seg2
                    if t < 0.0:
                        t = 0.0
                    elif t > 1.0:
                        t = 1.0
                else:
                    dist = np.hypot(rx, ry)
                    t = 0.0
                e1 = dist / tol
                e2 = np.abs(pit[i] - (wa + t * dw)) / pitch_tol
                if e1 != e1 or e2 != e2:
                    continue  # NaN: ignored, as fmax.reduceat ignores it
                err = e1 if e1 >= e2 else e2
                if m < 0 or err > worst:
                    worst = err
                    m = i
            if m >= 0 and worst > 1.0:
                keep[m] = True
                stack[top, 0] = a
                stack[top, 1] = m
                stack[top + 1, 0] = m
                stack[top + 1, 1] = z
                top += 2


def rdp_keep(px, py, pit, starts, ends, tol: float, pitch_tol: float, keep: np.ndarray) -> None:
    """Mark in ``keep`` (N,) bool the vertices the split keeps (as the numpy pass of ``simplify_mask``).

    Parameters
    ----------
    px, py, pit : (N,) float64
        Vertices (mm) and their pitch (mm), every path one after the other.
    starts, ends : (P,) int64
        Each path's first row and the row past its last.
    tol, pitch_tol : float, mm
    keep : (N,) bool
        Updated in place; the paths' ends are the caller's to set.
    """
    _rdp(
        np.ascontiguousarray(px, dtype=np.float64),
        np.ascontiguousarray(py, dtype=np.float64),
        np.ascontiguousarray(pit, dtype=np.float64),
        np.ascontiguousarray(starts, dtype=np.int64),
        np.ascontiguousarray(ends, dtype=np.int64),
        float(tol),
        float(pitch_tol),
        keep,
    )


@_njit
def _runs(w, is_short, first, limit, run):  # pragma: no cover - compiled
    k = -1
    have = False
    lo = 0.0
    hi = 0.0
    for i in range(w.shape[0]):
        if first[i]:
            k += 1
            have = False
        if is_short[i] and have:
            run[i] = k
            continue
        wi = w[i]
        if not have:
            lo = wi
            hi = wi
            have = True
            if k < 0:
                k = 0
        else:
            nlo = wi if wi < lo else lo
            nhi = wi if wi > hi else hi
            if nhi <= nlo * limit:
                lo = nlo
                hi = nhi
            else:
                k += 1
                lo = wi
                hi = wi
        run[i] = k


def run_index(width: np.ndarray, is_short: np.ndarray, first: np.ndarray, limit: float) -> np.ndarray:
    """Run index per segment, as :func:`loadpath.splice.beadruns.runs_of_widths` gives it.

    Parameters
    ----------
    width : (n,) float64, mm
    is_short, first : (n,) bool
        Segments shorter than the runs' ``short``; segments that begin a chain.
    limit : float
        ``1 + step``: the largest ratio of a run's widest width to its narrowest.

    Returns
    -------
    (n,) int64
    """
    run = np.zeros(len(width), dtype=np.int64)
    _runs(
        np.ascontiguousarray(width, dtype=np.float64),
        np.ascontiguousarray(is_short, dtype=np.bool_),
        np.ascontiguousarray(first, dtype=np.bool_),
        float(limit),
        run,
    )
    return run
