"""Compiled kernel of the path-end extensions (:mod:`.ends`): the first blocked candidate of each end.

:func:`.ends.extend_ends` places candidate points one ``step`` apart ahead of every path end and
keeps the candidates up to the first one that fails.  :func:`first_blocked` walks each end's
candidates in order and stops at the first failure, so the (candidate, path sample) pairs past it
are never looked at: on a bracket layer with a few thousand ends most candidates lie past the
first failure.  The path samples are found through a uniform cell grid
(:func:`.kernel_widths.cell_lists`, cells ``r_max`` wide); the tests are those of the module
docstring of :mod:`.ends`, pair by pair.
"""

from __future__ import annotations

import numpy as np
from loadpath.engines.finish._numba import njit

__all__ = ["first_blocked"]


@njit
def first_blocked(
    cand: np.ndarray,
    ok: np.ndarray,
    s: np.ndarray,
    end_pt: np.ndarray,
    end_dir: np.ndarray,
    end_w: np.ndarray,
    end_pid: np.ndarray,
    end_arc: np.ndarray,
    dp: np.ndarray,
    did: np.ndarray,
    dw: np.ndarray,
    darc: np.ndarray,
    origin: np.ndarray,
    cell: float,
    nx: int,
    ny: int,
    start: np.ndarray,
    items: np.ndarray,
    r_max: float,
    clear: float,
    cap: float,
    overlap: float,
    own_far: float,
) -> np.ndarray:
    """Index of the first candidate of each end that fails (``n_s`` where none does).

    Parameters
    ----------
    cand : (e, n_s, 2) float, mm
        Candidates ahead of each end, ``s[j]`` from it along ``end_dir``.
    ok : (e, n_s) bool
        Candidates that pass the region and field tests.
    s : (n_s,) float, mm
    end_pt, end_dir : (e, 2) float
        Each end and its outward unit direction.
    end_w : (e,) float, mm
        Its flow width.
    end_pid : (e,) int; end_arc : (e,) float, mm
        Its path and its arc length along that path.
    dp : (m, 2) float, mm; did : (m,) int; dw : (m,) float, mm; darc : (m,) float, mm
        Samples of the paths: point, path, width, arc length.
    origin, cell, nx, ny, start, items
        Grid of the samples (:func:`.kernel_widths.cell_lists`, ``cell >= r_max``).
    r_max : float, mm
        Samples farther than this from a candidate cannot block it.
    clear : float, mm
        Smallest centre-line distance to another path.
    cap : float
        Widths of its own an end keeps from the bead ahead, beyond touching it.
    overlap : float
        Share of its own width the new bead may cover of the beads beside it; NaN: centre-line
        clearance only.
    own_far : float, mm
        Samples of the end's own path nearer than this along it are ignored.

    Returns
    -------
    (e,) int64
    """
    n_e, n_s = ok.shape
    out = np.full(n_e, n_s, dtype=np.int64)
    lateral = not np.isnan(overlap)
    for e in range(n_e):
        ex, ey = end_pt[e, 0], end_pt[e, 1]
        tx, ty = end_dir[e, 0], end_dir[e, 1]
        w_e = end_w[e]
        for j in range(n_s):
            if not ok[e, j]:
                out[e] = j
                break
            cx, cy = cand[e, j, 0], cand[e, j, 1]
            i0 = max(int(np.floor((cx - r_max - origin[0]) / cell)), 0)
            i1 = min(int(np.floor((cx + r_max - origin[0]) / cell)), nx - 1)
            j0 = max(int(np.floor((cy - r_max - origin[1]) / cell)), 0)
            j1 = min(int(np.floor((cy + r_max - origin[1]) / cell)), ny - 1)
            bad = False
            for gi in range(i0, i1 + 1):
                for gj in range(j0, j1 + 1):
                    c = gi * ny + gj
                    for m in range(start[c], start[c + 1]):
                        k = items[m]
                        qx, qy = dp[k, 0], dp[k, 1]
                        d = np.hypot(qx - cx, qy - cy)
                        if d > r_max:
                            continue
                        if did[k] == end_pid[e] and abs(darc[k] - end_arc[e]) <= own_far:
                            continue
                        ahead_bad = d < max(clear, 0.5 * dw[k] + cap * w_e)
                        if not lateral:
                            bad = ahead_bad
                        else:
                            rx, ry = qx - ex, qy - ey
                            u = rx * tx + ry * ty
                            v = abs(rx * ty - ry * tx)
                            if u > s[j]:
                                bad = ahead_bad
                            else:
                                dx = max(max(u - s[j], -u), 0.0)
                                dy = max(v - 0.5 * w_e, 0.0)
                                bad = (
                                    (dx == 0.0 and dy == 0.0)
                                    or np.hypot(dx, dy) < 0.5 * dw[k] - overlap * w_e
                                    or d < clear
                                )
                        if bad:
                            break
                    if bad:
                        break
                if bad:
                    break
            if bad:
                out[e] = j
                break
    return out
