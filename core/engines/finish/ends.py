"""Path ends carried on to what stops them: the next bead, or the layer's edge.

An engine's path often ends short of what it runs into: a swarm agent is removed a whole step
before a path laid earlier (its next location would be too close), two fronts meeting behind a
hole stop a pitch or more apart, a streamline is cut where its spacing check fails.  The beads
then leave a void in front of each such end: small per end, but hundreds of ends line the seams
between fronts, the edge of the layer and the rims of holes, and a void costs stiffness in
proportion to its area (the printed part is only as stiff as its material is dense).

:func:`extend_ends` moves every path end straight on, along its last direction, as far as it can
go while

* it stays ``edge_gap`` pitches inside the region (as the swarm's own last step does: the bead
  then reaches just past the edge, like a slicer's infill meeting its perimeter), and
* its centre line keeps ``clearance`` from every other path's centre line, and from the other
  ends' extensions: at least half the pitch, and at least half the other bead's width plus
  ``cap`` of its own (:data:`_CAP`), so the new bead end meets the bead it runs into without
  covering it, and the half-pitch rule of the engines still holds;
* with ``overlap`` set, the new piece of bead (a rectangle from the old end, as wide as the end's
  bead) also covers at most ``overlap`` of its own width of the beads *beside* it: an end
  squeezed between converging neighbours does not run on along them.  The swarm engine uses 0:
  on the small test bracket's layer (flat-ended beads) overlap falls from 7.4 to 4.2 % while
  coverage falls from 96.1 to 91.4 %, and the stiffness benchmark's bracket gains (0.32 -> 0.49
  of the model's ceiling gain at equal mass: the overlapping plastic was taken from everywhere
  else by volume matching).  ``None``, the centre-line test alone, suits the streamline engine
  (0.63 against 0.55 with 0), whose ends are seldom squeezed;

while the followed stress keeps within ``max_turn`` degrees of its direction, and at most
``reach`` pitches.  Extensions shorter than ``min_length`` pitches are dropped (the
splicer would simplify them away anyway).  Two ends heading for each other (fronts meeting
head-on) share the gap: where their extensions conflict, the longer one gives way, step by step.

Candidate points every ``step`` mm ahead of each end are tested against the region and the
field in vectorized calls; then a compiled kernel (:func:`.kernel_ends.first_blocked`) walks each
end's candidates in order against the densified paths near them (a cell grid) and stops at the
first that fails, so the pairs past it are never examined (the same result as testing every pair:
on the bench bracket 58 ms instead of 239 ms).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.finish import kernel_ends as ke
from loadpath.engines.finish import kernel_widths as kw
from scipy.spatial import cKDTree

__all__ = ["extend_ends"]

_CAP = 0.25
"""An end stops this many of its own widths short of the bead it runs into (beyond touching it),
between a square end (touching at 0) and a round one (0.5); a printed bead end is neither, and
0.25 keeps the round-bead overlap of the coverage metric within 3 % on the engine tests (0.125 and
0 do not: 3.7 % on the radial two-island case) and the swarm's K ordering of curved-field beta."""

_SAMPLE = 0.2
"""Spacing of the samples of the paths the extensions are checked against, in pitches."""

_MARGIN = 0.02
"""Added to the clearance, in pitches: the candidates and the paths are sampled, not exact."""


def _segments(paths: Sequence[Points2], widths: Sequence[Floats]):
    """Every segment of every path: ends, widths at the ends, path id, arc length at its start."""
    counts = np.array([len(p) for p in paths])
    pts = np.concatenate(paths)
    wid = np.concatenate(widths)
    pid = np.repeat(np.arange(len(paths)), counts)
    last = np.zeros(len(pts), dtype=bool)
    last[np.cumsum(counts) - 1] = True
    seg = np.hypot(*np.diff(pts, axis=0).T)
    seg = np.where(last[:-1], 0.0, seg)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    first = np.repeat(np.cumsum(counts) - counts, counts)
    arc = arc - arc[first]
    i = np.flatnonzero(~last[:-1])
    return pts[i], pts[i + 1], wid[i], wid[i + 1], pid[i], arc[i]


def _densify(a: Points2, b: Points2, wa: Floats, wb: Floats, pid: np.ndarray, arc: Floats, spacing: float):
    """Points at most ``spacing`` apart along segments (both ends included), with path id, width, arc."""
    seg = np.hypot(*(b - a).T)
    n = np.maximum(1, np.ceil(seg / spacing).astype(np.int64)) + 1
    rep = np.repeat(np.arange(len(a)), n)
    frac = (np.arange(len(rep)) - np.repeat(np.cumsum(n) - n, n)) / (n[rep] - 1)
    q = a[rep] + frac[:, None] * (b - a)[rep]
    return q, pid[rep], wa[rep] + frac * (wb - wa)[rep], arc[rep] + frac * seg[rep]


def _first_blocked(
    cand: np.ndarray,
    ok: np.ndarray,
    s: Floats,
    end_pt: Points2,
    end_dir: Points2,
    end_w: Floats,
    end_pid: np.ndarray,
    end_arc: Floats,
    dp: Points2,
    did: np.ndarray,
    dw: Floats,
    darc: Floats,
    r_max: float,
    clear: float,
    cap: float,
    overlap: float | None,
    own_far: float,
) -> np.ndarray:
    """Index of the first failing candidate of each end, (e,) int (:func:`.kernel_ends.first_blocked`).

    Puts the path samples ``dp`` in a grid of ``r_max`` cells over them and the candidates that
    pass ``ok``, and runs the kernel; ``overlap`` None is the centre-line clearance only.
    """
    at = cand.reshape(-1, 2)[ok.ravel()]
    lo = np.minimum(dp.min(axis=0, initial=np.inf), at.min(axis=0, initial=np.inf)) - r_max
    hi = np.maximum(dp.max(axis=0, initial=-np.inf), at.max(axis=0, initial=-np.inf)) + r_max
    nx, ny = (np.floor((hi - lo) / r_max).astype(np.int64) + 1).tolist()
    start, items = kw.cell_lists(dp, np.zeros(0, dtype=np.int64), np.arange(len(dp)), lo, r_max, nx, ny)
    return ke.first_blocked(
        cand,
        ok,
        s,
        end_pt,
        end_dir,
        end_w,
        end_pid,
        end_arc,
        dp,
        did,
        dw,
        darc,
        lo,
        float(r_max),
        nx,
        ny,
        start,
        items,
        float(r_max),
        float(clear),
        float(cap),
        np.nan if overlap is None else float(overlap),
        float(own_far),
    )


def extend_ends(
    paths: Sequence[Points2],
    widths: Sequence[Floats],
    region: Region,
    pitch: float,
    reach: float = 3.0,
    edge_gap: float = 0.25,
    min_length: float = 0.1,
    step: float | None = None,
    clearance: float | None = None,
    field: object | None = None,
    max_turn: float = 30.0,
    cap: float = _CAP,
    overlap: float | None = None,
) -> tuple[list[Points2], list[Floats], dict]:
    """Carry every path end on to the next bead or the region's edge (module docstring).

    Parameters
    ----------
    paths : sequence of (n_i, 2) float, mm
    widths : sequence of (n_i,) float, mm
        Flow width (local pitch) at every point.
    region : Polygon or MultiPolygon, mm
    pitch : float, mm
        Nominal pitch.
    reach : float
        Longest extension, in pitches.
    edge_gap : float
        Extended ends keep this many pitches inside the region.
    min_length : float
        Shorter extensions are dropped, in pitches.
    step : float, mm, optional
        Spacing of the candidate points (default a ninth of the pitch).
    clearance : float, mm, optional
        Smallest centre-line distance of an extension to other paths (default half the pitch;
        the streamline engine passes its ``min_spacing``).  A margin of 2 % of the pitch covers
        the sampling of the candidates and of the paths.
    field : StressField, optional
        The followed stress: an extension stops where the principal direction turns more than
        ``max_turn`` degrees away from it (a straight piece must not cut across a curving field,
        nor run over a jump of the followed stress).  Where the field has no direction the
        extension goes on.
    max_turn : float, degrees
    cap : float
        How far short of the bead it runs into an end stops, in its own widths (:data:`_CAP`).
    overlap : float, optional
        How much of its own width an extension may cover of the beads beside it (module
        docstring); ``None`` checks only the centre-line clearance.

    Returns
    -------
    paths : list of (m_i, 2) float
        Each path with at most one new point before its start and one after its end.
    widths : list of (m_i,) float
        The new points carry the width of the end they extend.
    stats : dict
        ``ends_extended`` (count) and ``extension_mm`` (total length).
    """
    paths = [np.asarray(p, dtype=float) for p in paths]
    widths = [np.asarray(w, dtype=float) for w in widths]
    stats = {"ends_extended": 0, "extension_mm": 0.0}
    keep = [
        i
        for i, p in enumerate(paths)
        if len(p) >= 2 and np.hypot(*(p[-1] - p[-2])) > 0 and np.hypot(*(p[1] - p[0])) > 0
    ]
    if not keep:
        return list(paths), list(widths), stats
    step = float(step) if step else pitch / 9.0
    clear = (float(clearance) if clearance else 0.5 * pitch) + _MARGIN * pitch
    # ends: (path, which end) -> point, outward direction, width
    idx = np.array(keep, dtype=np.int64)
    head = np.array([paths[i][0] for i in keep])
    head_dir = head - np.array([paths[i][1] for i in keep])
    tail = np.array([paths[i][-1] for i in keep])
    tail_dir = tail - np.array([paths[i][-2] for i in keep])
    end_pt = np.vstack([head, tail])
    end_dir = np.vstack([head_dir, tail_dir])
    end_dir /= np.hypot(*end_dir.T)[:, None]
    end_pid = np.concatenate([idx, idx])
    end_w = np.concatenate([[widths[i][0] for i in keep], [widths[i][-1] for i in keep]])
    is_tail = np.repeat([False, True], len(keep))
    kept = np.concatenate([paths[i] for i in keep])
    step_len = np.hypot(*np.diff(kept, axis=0).T)
    first = np.cumsum([0] + [len(paths[i]) for i in keep])[:-1]
    step_len[first[1:] - 1] = 0.0  # the jump from one path to the next
    lengths = np.add.reduceat(np.append(step_len, 0.0), first)
    end_arc = np.concatenate([np.zeros(len(keep)), lengths])

    # candidate points ahead of every end
    n_s = int(np.ceil(reach * pitch / step))
    s = step * np.arange(1, n_s + 1)
    cand = end_pt[:, None, :] + s[None, :, None] * end_dir[:, None, :]  # (e, n_s, 2)
    flat = cand.reshape(-1, 2)
    inner = region.buffer(-edge_gap * pitch) if edge_gap > 0 else region
    shapely.prepare(inner)
    ok = shapely.contains_xy(inner, flat[:, 0], flat[:, 1])
    if field is not None:
        live = np.flatnonzero(ok)
        if len(live):
            smp = field.sample(flat[live])  # type: ignore[attr-defined]
            dirs = np.repeat(end_dir, n_s, axis=0)[live]
            cos = np.abs(np.sum(smp.direction * dirs, axis=1))
            ok[live] = ~smp.valid | (cos >= np.cos(np.radians(max_turn)))
    ok = ok.reshape(len(end_pt), n_s)

    # clearance from the paths (own path: only points far along it from this end)
    # paths sampled every _SAMPLE pitches: the nearest sample is at most (_SAMPLE / 2)^2 / (2 d)
    # farther than the path itself, 0.01 pitch at half a pitch, within the margin
    # (only the segments that come near a candidate)
    sa, sb, swa, swb, spid, sarc = _segments(paths, widths)
    r_max = (
        max(
            clear,
            0.5 * float(max(swa.max(), swb.max()))
            + (cap if overlap is None else max(cap, 0.5)) * float(end_w.max()),
        )
        + step
    )
    live = np.flatnonzero(ok.ravel())
    own_far = (reach + 1.0) * pitch
    if len(live):
        ctree = cKDTree(flat[live])
        half = 0.5 * np.hypot(*(sb - sa).T)
        dmid, _ = ctree.query(0.5 * (sa + sb), distance_upper_bound=r_max + float(half.max()))
        near = dmid <= r_max + half
        dp, did, dw, darc = _densify(
            sa[near], sb[near], swa[near], swb[near], spid[near], sarc[near], _SAMPLE * pitch
        )
        first_bad = _first_blocked(
            cand,
            ok,
            s,
            end_pt,
            end_dir,
            end_w,
            end_pid,
            end_arc,
            dp,
            did,
            dw,
            darc,
            r_max,
            clear,
            cap,
            overlap,
            own_far,
        )
    else:
        first_bad = np.zeros(len(end_pt), dtype=np.int64)
    # extension: the candidates up to the first failing one
    length = np.where(first_bad > 0, s[np.maximum(first_bad - 1, 0)], 0.0)

    # ends heading for each other: the longer extension gives way until they keep the clearance
    for _ in range(2 * n_s):
        live = np.flatnonzero(length > 0)
        if len(live) < 2:
            break
        k = np.round(length[live] / step).astype(np.int64)
        e_rep = np.repeat(live, k)
        j = np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k)
        q = cand[e_rep, j]
        pairs = cKDTree(q).query_pairs(clear, output_type="ndarray")
        if not len(pairs):
            break
        a, b = e_rep[pairs[:, 0]], e_rep[pairs[:, 1]]
        diff = end_pid[a] != end_pid[b]
        a, b = a[diff], b[diff]
        if not len(a):
            break
        longer = np.where(length[a] >= length[b], a, b)
        length[np.unique(longer)] -= step
        length = np.maximum(length, 0.0)
    length = np.where(length >= min_length * pitch, length, 0.0)

    out_p, out_w = list(paths), list(widths)
    for e in np.flatnonzero(length > 0):
        i = int(end_pid[e])
        new = end_pt[e] + length[e] * end_dir[e]
        if is_tail[e]:
            out_p[i] = np.vstack([out_p[i], new])
            out_w[i] = np.append(out_w[i], end_w[e])
        else:
            out_p[i] = np.vstack([new, out_p[i]])
            out_w[i] = np.insert(out_w[i], 0, end_w[e])
    stats["ends_extended"] = int(np.count_nonzero(length > 0))
    stats["extension_mm"] = float(length.sum())
    return out_p, out_w, stats
