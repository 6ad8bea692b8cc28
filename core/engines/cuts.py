"""Cut links: two free run ends with one path between them, joined through a cut in that path.

After linking (:func:`loadpath.engines.linking.link_paths`) most runs of a layer still end inside
the region (issue 19, ``benchmarks/where_ends.py``): a swarm path squeezed out between two
neighbours that close up, a streamline cut by its spacing check.  Such an end is an odd vertex
of the layer's path graph, and a link can only pair two odd vertices: an end with another path
between it and every other free end costs half a run, and on PrusaSlicer's
``retract_before_travel = 1`` mm a retraction, whatever the linking does.

Where two such free ends lie on either side of one path ``A`` (``e1`` above it, ``e2`` below), a
short cut in ``A`` pairs them::

      P1 -----------e1                P1 -----------+
                                                    |        (hairpin into A's first piece)
      A  ------------------   ->      A  ---------+ +-------
                                                    |        (bridge onto A's second piece)
      P2 ---------------e2            P2 ---------------+

The cut leaves two new ends ``j0`` and ``j1`` about a pitch apart where ``e1`` and ``e2`` meet
``A``; the linking, run again on the cut paths, joins ``e1`` to one and ``e2`` to the other if
its own tests accept them (inside the region, clear of every other path and link, no loop).
Parity: ``e1`` and ``e2`` lose their odd degree, ``j0`` and ``j1`` are paired, so three runs (the
two runs of ``e1`` and ``e2`` and the one through ``A``) become two.  The gap in ``A`` is covered by
the two links' beads, each a pitch wide.  With two or three paths between the ends, each is cut
where the segment between the ends crosses it: a staircase of short links.

:func:`cut_paths` picks the cuts: pairs of free run ends of different runs within ``reach``
pitches, neither with another run's end within ``hop`` mm (the nozzle would go there primed: no
retraction to save), whose straight segment crosses one to ``max_cross`` other paths once each,
where the stress is low (``field``, ``stress_share``), the closest pairs first, each end once and
cuts on one path well apart.  :func:`loadpath.engines.linking.link_paths` relinks the cut paths,
the earlier links first and new links only between the ends of the cuts, and keeps them only when
fewer groups of runs are left apart (:func:`loadpath.engines.linking.hop_groups`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from loadpath._typing import Points2
from loadpath.toolpath import Path

__all__ = ["cut_paths", "free_ends"]


def free_ends(runs: Sequence[Path]) -> Points2:
    """The two ends of every run, (2 r, 2) float mm: run ``i``'s start at ``2 i``, its end at ``2 i + 1``."""
    if not runs:
        return np.zeros((0, 2))
    return np.array([q for r in runs for q in (r.points[0], r.points[-1])], dtype=float)


def _piece(p: Path, s0: float, s1: float) -> Path | None:
    """The part of ``p`` between arc lengths ``s0 < s1`` (mm), with its pitch interpolated; None if
    shorter than a micrometre."""
    if s1 - s0 < 1e-3:
        return None
    seg = np.hypot(*np.diff(p.points, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    inner = (arc > s0) & (arc < s1)
    s = np.concatenate([[s0], arc[inner], [s1]])
    x = np.interp(s, arc, p.points[:, 0])
    y = np.interp(s, arc, p.points[:, 1])
    w = np.interp(s, arc, p.pitch)
    return Path(np.column_stack([x, y]), w, p.kind)


def _stress(field: object, points: Points2) -> np.ndarray:
    """Magnitude of the followed principal stress of ``field`` at ``points`` (n, 2) mm: (n,) float MPa."""
    return field.sample(points).magnitude  # type: ignore[attr-defined]


def cut_paths(
    paths: Sequence[Path],
    runs: Sequence[Path],
    pitch: float,
    reach: float = 2.5,
    gap: float = 1.0,
    max_cross: int = 3,
    hop: float = 0.0,
    field: object | None = None,
    stress_share: float = 0.5,
) -> tuple[list[Path], int, Points2]:
    """The paths with cuts wherever two free run ends have one to ``max_cross`` paths between them.

    The segment between the two ends crosses each path between them once; each is cut ``gap``
    pitches long, centred where the segment crosses it.  A segment at a slant to the paths leaves
    the cuts staggered, a staircase of short links from one end to the other.

    Parameters
    ----------
    paths : sequence of Path
        The layer's paths as the linking took them (after its fragments were dropped).
    runs : sequence of Path
        The runs linked from them: their ends are the free ends.
    pitch : float, mm
        Nominal pitch (unit of ``reach`` and ``gap``).
    reach : float
        Largest distance of the two free ends, in pitches.
    gap : float
        Length of a cut, in pitches: the links it takes must keep the linking's clearance (half a
        pitch) from each other's far piece.
    max_cross : int
        Most paths cut for one pair of ends.
    hop : float, mm
        Ends with another run's end within this distance are left alone: the nozzle travels
        between them without a retraction anyway.
    field : StressField, optional
        The followed stress: a path is cut only where its magnitude is at most ``stress_share``
        of its 90th percentile over the layer's path vertices (a cut is a bead end, and bead ends
        weaken a path most where it carries most).  None: anywhere.
    stress_share : float
        That share.

    Returns
    -------
    paths : list of Path
        The paths, each cut one replaced by its pieces (a piece may be missing where a cut reaches
        the path's end).
    cuts : int
        How many cuts.
    touched : (m, 2) float, mm
        The ends the cuts are for: the paired free ends and the new ends at the cuts (the only
        ends the relinking may join anew).
    """
    from scipy.spatial import cKDTree  # imported here: a run whose links come from the cache needs no scipy

    ps = list(paths)
    ends = free_ends(runs)
    none = np.zeros((0, 2))
    if len(ps) < 2 or len(ends) < 4:
        return ps, 0, none
    rid = np.repeat(np.arange(len(runs)), 2)
    tree_e = cKDTree(ends)
    lonely = np.ones(len(ends), dtype=bool)
    if hop > 0:
        for i, nb in enumerate(tree_e.query_ball_point(ends, hop)):
            lonely[i] = all(rid[k] == rid[i] for k in nb)
    pairs = tree_e.query_pairs(reach * pitch, output_type="ndarray")
    if not len(pairs):
        return ps, 0, none
    pairs = pairs[(rid[pairs[:, 0]] != rid[pairs[:, 1]]) & lonely[pairs[:, 0]] & lonely[pairs[:, 1]]]
    if not len(pairs):
        return ps, 0, none
    limit = np.inf
    if field is not None:
        mag = _stress(field, np.concatenate([p.points for p in ps]))
        mag = mag[np.isfinite(mag)]
        if len(mag):
            limit = stress_share * float(np.quantile(mag, 0.9))
    d = np.hypot(*(ends[pairs[:, 0]] - ends[pairs[:, 1]]).T)
    pairs = pairs[np.argsort(d, kind="stable")]
    lines = np.array([shapely.LineString(p.points) for p in ps], dtype=object)
    tree = shapely.STRtree(lines)
    segs = shapely.linestrings(np.stack([ends[pairs[:, 0]], ends[pairs[:, 1]]], axis=1))
    seg_i, path_i = tree.query(segs, predicate="intersects")
    # a path that touches the segment at one of its two ends is the end's own path
    own = shapely.distance(lines[path_i], shapely.points(ends[pairs[seg_i, 0]])) < 1e-6
    own |= shapely.distance(lines[path_i], shapely.points(ends[pairs[seg_i, 1]])) < 1e-6
    seg_i, path_i = seg_i[~own], path_i[~own]
    count = np.bincount(seg_i, minlength=len(pairs))
    used_end = np.zeros(len(ends), dtype=bool)
    cut_at: dict[int, list[tuple[float, float]]] = {}
    half = 0.5 * gap * pitch
    for k in np.flatnonzero((count >= 1) & (count <= max_cross)):
        a, b = pairs[k]
        if used_end[a] or used_end[b]:
            continue
        crossed = path_i[seg_i == k]
        if len(set(crossed.tolist())) != len(crossed):
            continue
        xs = shapely.intersection(lines[crossed], segs[k])
        if not np.all(shapely.get_type_id(xs) == 0):  # each crossed once, at a point
            continue
        if np.isfinite(limit):
            at = _stress(field, shapely.get_coordinates(xs))
            if not np.all(np.nan_to_num(at, nan=np.inf) <= limit):
                continue
        s = shapely.line_locate_point(lines[crossed], xs)
        free = all(
            all(abs(c - sc) > 2 * half + gap * pitch for sc, _ in cut_at.get(int(i), []))
            for i, c in zip(crossed, s, strict=True)
        )
        if not free:
            continue
        for i, c in zip(crossed, s, strict=True):
            cut_at.setdefault(int(i), []).append((float(c), half))
        used_end[a] = used_end[b] = True
    if not cut_at:
        return ps, 0, none
    out: list[Path] = []
    touched = [ends[used_end]]
    for i, p in enumerate(ps):
        if i not in cut_at:
            out.append(p)
            continue
        total = p.length
        edges = [0.0]
        for c, h in sorted(cut_at[i]):
            edges += [max(c - h, 0.0), min(c + h, total)]
        edges.append(total)
        for s0, s1 in zip(edges[::2], edges[1::2], strict=True):
            piece = _piece(p, s0, s1)
            if piece is not None:
                out.append(piece)
                if s0 > 0.0:
                    touched.append(piece.points[:1])
                if s1 < total:
                    touched.append(piece.points[-1:])
    return out, sum(len(v) for v in cut_at.values()), np.concatenate(touched)
