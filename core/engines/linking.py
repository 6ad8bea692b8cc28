"""Continuous runs: a layer's paths linked end to end the way a slicer links its infill lines.

A shared finishing stage for every engine's output (the pipeline applies it to each job's paths, to
the staggered copies and to every principal direction; :func:`link_paths`).  The engines return
hundreds of separate paths per layer; printed one by one, each costs a travel and, on PrusaSlicer's
``retract_before_travel = 1`` mm, a retraction (issue 19: 12-59x the slicer's retractions).  A
slicer's rectilinear infill is a few zig-zags: each line's end is linked to its neighbour's by a
printed piece along the infill domain's edge.

Two kinds of link join the end of one path to the end of another (never two ends of one path):

hairpin / bridge
    the straight segment between two ends (neighbours that end side by side, or fronts that meet
    head-on);
boundary link
    when the straight segment leaves the region or comes too close to another path, and both ends
    lie near the domain's edge: the piece of the edge between the two ends, taken at the ends'
    own inset (the slicer's zig-zag connection), from one end to the other.

A link is accepted when

* it is at most ``max_link`` pitches long;
* it leaves each end at most ``max_turn`` degrees off the end's own direction;
* it lies inside the region and keeps ``clearance`` pitches from every other path, and from its
  own two paths except within a pitch of the ends it joins (further where a path meets the edge at
  a shallow angle, :attr:`LinkOptions.wedge`) (sampled every quarter pitch; so it
  crosses nothing and never runs back along its own path), and from every link accepted before it;

each end once, never closing a loop (union-find), so the result is chains.  The links are chosen
two ways and the one with fewer runs is kept (:attr:`LinkOptions.grow_chains`): chains grown end
by end from a free end, each taking its shortest acceptable link (:func:`_grow`, how a slicer
chains its lines), and all candidates shortest first over the layer.
Each link is printed with the pitch of its ends (interpolated along it): the flow of the local
pitch.  Free ends left with paths between them can then be paired through short cuts in those
paths, where the stress is low (:mod:`loadpath.engines.cuts`, :attr:`LinkOptions.cut_reach`).
Short pieces that cost a travel and add little are dropped first (:func:`drop_fragments`), and the
runs left without a link that cover less than ``lone_area`` square pitches last (:func:`drop_lone`).

Two more things a layer's runs end on less (issue 19).  An engine may say where its paths end inside
the region by design (:attr:`loadpath.toolpath.Toolpaths.band`: the level sets' cut along a bending
part's neutral axis): the band's edge is then an edge like the region's (``band``,
:attr:`LinkOptions.band_depth`).  And after the greedy passes a run may take the place of a link laid
before it (:mod:`loadpath.engines.insertion`, :attr:`LinkOptions.insert`).

The runs are returned in no particular order: the splicer orders them (nearest neighbour from the
nozzle, then 2-opt; :func:`loadpath.splice.plan.order_paths`).

Measured (``benchmarks/bench_printability.py``, issue 19): a layer of the bench's tension bar,
114 swarm paths -> 28 runs, coverage 0.9919 -> 0.9931; the overlap metric (each run one bead)
1.06 -> 0.58 %, counted with every link a bead of its own (:func:`pieces`) 2.9 %: a link lies on
the two ends it joins, as a slicer's zig-zag turn does.

Both ways share one preparation of the layer (:class:`_Layer`: the fragments dropped, the ends,
the samples and their trees, the candidates) and each candidate's geometric test, made once: it
does not depend on the links laid before (issue 17: the example's linking 3.5x less CPU, the same
runs).  What costs little per candidate once batched is made for all candidates at the first one
tried: every straight candidate's samples and clearance (one tree query), every boundary
candidate's ring piece (:func:`loadpath.engines.edge_links.ring_pieces`), samples and containment;
a boundary link's turn, length and clearance are tested only when a pass tries it (most are never
tried, and their clearance queries, batched, cost more than the ones tried one by one).  The same
runs as one test at a time (``tests/linking_reference.py``).

(Over 400 lines: the search shares its end, sample and tree arrays with the acceptance test of
both kinds of link and both passes; split, they would pass a dozen arrays around.)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import shapely
from loadpath._typing import Points2, Region
from loadpath.engines.cuts import cut_paths
from loadpath.engines.edge_links import Rings, ring_pieces, shrunk_rings
from loadpath.engines.exact_links import MIP_CANDIDATES, exact_links
from loadpath.errors import SettingsError
from loadpath.toolpath import Path

__all__ = ["LinkOptions", "LONE_AREA_RANGE", "link_paths", "drop_fragments", "drop_lone", "pieces"]


@dataclass(frozen=True)
class LinkOptions:
    """How paths are linked into runs (module docstring).

    Attributes
    ----------
    max_link : float
        Longest straight link, in nominal pitches.
    max_edge_link : float
        Longest boundary link, in nominal pitches (ends that meet the edge at a slant lie several
        pitches apart along it).
    max_long_link : float
        Longest straight link of the second pass (ends left free by the first), in pitches: such a
        link runs only through what no path covers (the clearance), e.g. across a void.
    max_turn : float, degrees
        Largest angle between an end's outward direction and the link leaving it.
    clearance : float
        Smallest distance of a link to other paths and links, in pitches.
    edge_reach : float
        An end within this many pitches of the region's edge may take a boundary link.
    min_fragment : float
        Runs shorter than this many pitches are dropped when most of their bead lies on others'
        (:func:`drop_fragments`); 0: keep every run.
    fragment_share : float
        A short run is dropped when less than this share of its bead covers what no other bead does.
    link_width : float
        A link's pitch (its flow width) as a share of its ends' pitch.
    lone_area : float, square pitches
        A run left without a link whose bead covers less than this area (its length times its
        pitch) is dropped: an isolated stub costs a travel and a retraction and covers next to
        nothing (volume matching gives its plastic to the rest).  0: keep every run.  Bounds:
        :data:`LONE_AREA_RANGE`.  5 (3 before 2026-12-06): where a level set grazes the edge it
        leaves a stub 1.6-1.7 mm long on the bench's bar (0.49-0.52 mm², either side of 3 square
        pitches), kept or dropped by a micrometre's shift of the field.  ``bench_printability.py
        --engine default``, four draws of that shift (``benchmarks/printability_results.md``,
        twentieth round): PrusaSlicer retractions 375-396 -> 364-385 in total, no row higher in any
        draw; stiffness and failure load lower by at most 0.0002, coverage by 0.0003.
    lone_share : float
        At most this share of the layer's bead area is dropped as lone runs (the smallest first).
        The bench's solid layers drop 0-0.45 % (PrusaSlicer 100 %); sparse layers of CuraEngine
        files 1-3 %, where the engine already lays only ~86 % of the slicer's plastic and volume
        matching is at its bound (``PlanOptions.max_correction``): whatever is dropped there is
        lost, and without the share 4 of 8 blocks of the 40 % L-bracket (swarm) fell below the
        splice's 3 % volume tolerance and were kept as sliced (with 1 %: 4 of 8 of the beam's,
        streamlines).
    grow_chains : bool or None
        True: grow chains link by link from a free end (:func:`_grow`); False: accept the candidate
        links shortest first over the whole layer; None: both, keeping the one with fewer runs.
        Bench (``benchmarks/bench_printability.py``, PrusaSlicer 100 %, swarm, retractions): bar
        241 / 264 / 246, bracket 527 / 539 / 524 (shortest first / grown / both), and the two-island
        part 249 -> 139 grown: neither alone is best everywhere.
    cut_reach : float
        Two free run ends at most this many pitches apart with one to ``cut_cross`` paths between
        them are joined through cuts in those paths (:mod:`loadpath.engines.cuts`), when the
        layer then leaves fewer groups of runs apart (:func:`hop_groups`); 0 (the default): no
        cuts.  7 pitches reach the pairs with up to three paths between them; off by default
        because the bead model charges every cut (``cut_stress``): at the share that keeps the
        bench's stiffness the retractions fall by 0-3 %, the travel rises by up to 4 %, and one
        failure load is 0.02 % lower (``benchmarks/printability_results.md``, fourth round).
    cut_rounds : int
        How many times the cuts are looked for again on the runs the last ones gave.
    free_hop : float, mm
        A travel this short goes without a retraction (PrusaSlicer's ``retract_before_travel``,
        1 mm on its printer presets): cuts are made only for ends with no other run's end that
        near, and kept only when fewer groups of runs are left that such hops do not join.
    cut_stress : float
        Paths are cut only where the followed stress is at most this share of its 90th
        percentile at the layer's path vertices (with a field given to :func:`link_paths`).
        Bench (``benchmarks/bench_printability.py``, PrusaSlicer 100 %, swarm; retractions,
        stiffness, failure load; no cuts: beam 555, 1.0305, 0.9262, bracket 488, 1.0075, 0.9543):
        0.1: beam 538, 1.0306, 0.9265, bracket 484, 1.0076, 0.9571; 0.5: beam 389, 1.0290,
        0.9193, bracket 400, 1.0064, 0.9588.  More cuts, fewer retractions, and a little less
        stiffness (each cut is a bead broken where it carried something): 0.1 is the share at
        which neither fell on the bench (``benchmarks/printability_results.md``, fourth round).
    cut_gap : float
        Length of a cut, in pitches (:func:`loadpath.engines.cuts.cut_paths`).
    cut_cross : int
        Most paths cut to pair two ends.
    wedge : float, pitches
        A path that meets the edge at a shallow angle ``a`` converges on a link along the edge from
        its end: the link may run beside it for ``clearance / sin a`` and a pitch, at most this
        many pitches (:func:`_own_reach`); 0 (the default): two pitches, as for any end.  The
        level-set engine's paths reach a bending part's faces at a few degrees, their ends 5-20
        pitches apart along the edge: it links with 24 (and ``max_edge_link`` 24;
        :attr:`loadpath.engines.registry.Engine.linking`).  Bench (``benchmarks/bench_printability.py``,
        PrusaSlicer 100 %, retractions): beam 245 -> 100, bracket 245 -> 149, bar 75 -> 50.  The
        link's bead lies on the wedge between the path and the edge, as a slicer's zig-zag turn
        lies on its line ends.
    band_depth : float, pitches
        The engine's band (:attr:`loadpath.toolpath.Toolpaths.band`: where its paths end inside the
        region, the level sets' jump cut along a bending part's neutral axis) is an edge of its own
        where it lies deeper than this inside the region: ends on it are linked along it as ends on
        the region's edge are (a zig-zag along the cut), so they no longer end runs there.  Nearer
        the edge (the cut along a loaded face) the ends keep the region's edge: linked along the
        band there, the bench's bar at PrusaSlicer 100 % lost 10 % of its failure load (1.035 ->
        0.928x the slicer's; retractions 50 -> 45).  Negative: no band.
    insert : bool
        After the greedy passes, runs are inserted into links laid before them, and two runs
        share a link where their ends lie either side of it (:mod:`loadpath.engines.insertion`,
        swaps).  The pipeline turns it off for sparse infill: on the
        bench's 30 % gyroid bar it made one run of two whose ends both lay across the part from
        where the perimeters left the nozzle (travel 287 -> 637 mm, retractions 18 -> 18).
    exact : int
        Also choose the layer's links all at once, by an integer program over every candidate
        (:mod:`loadpath.engines.exact_links`), each solve taking at most this many branch-and-bound
        nodes; they are laid first and the greedy passes go on from them, and the result is kept
        where it leaves fewer runs.  0 (the default): not.  The level-set engine's solid infill is
        linked with 200 (its registry entry's ``linking``).
    exact_integers : int
        Layers with at most this many candidate links are solved in integers by the exact links,
        larger ones by the linear relaxation (default
        :data:`loadpath.engines.exact_links.MIP_CANDIDATES`; 0: always the relaxation).
    """

    max_link: float = 3.0
    max_edge_link: float = 12.0
    max_long_link: float = 8.0
    max_turn: float = 180.0
    clearance: float = 0.5
    edge_reach: float = 1.2
    min_fragment: float = 3.0
    fragment_share: float = 0.5
    link_width: float = 1.0
    lone_area: float = 5.0
    lone_share: float = 0.005
    grow_chains: bool | None = None
    cut_reach: float = 0.0
    cut_rounds: int = 2
    free_hop: float = 1.0
    cut_stress: float = 0.1
    cut_gap: float = 1.0
    cut_cross: int = 3
    wedge: float = 0.0
    band_depth: float = 3.0
    insert: bool = True
    exact: int = 0
    exact_integers: int = MIP_CANDIDATES

    def __post_init__(self) -> None:
        lo, hi = LONE_AREA_RANGE
        v = self.lone_area
        if not (isinstance(v, (int, float)) and math.isfinite(v) and lo <= v <= hi):
            raise SettingsError(
                f"linking lone_area = {v!r} square pitches is outside {lo:g}..{hi:g}; the area under "
                "which a run left without a link is dropped (0: keep every run)"
            )
        if not 0.0 <= self.lone_share <= 1.0:
            raise SettingsError(f"linking lone_share = {self.lone_share!r} must lie in 0..1")

    def for_bead(self, width: float, pitch: float) -> LinkOptions:
        """These options for paths printed ``width`` mm wide at ``pitch`` mm apart (sparse infill).

        ``clearance`` is in pitches; on solid infill the bead is the pitch.  Sparse beads are
        narrower than their spacing, and in its pitches the clearance kept a link a whole bead or
        more off its neighbours, leaving most ends unlinked.  Here it is the same share of the bead
        as on solid infill: ``clearance * width / pitch`` pitches (no change where ``width >=
        pitch``).

        Examples
        --------
        >>> o = LinkOptions()
        >>> round(o.for_bead(0.45, 1.125).clearance, 3), o.for_bead(0.45, 0.4).clearance
        (0.2, 0.5)
        """
        share = min(1.0, width / pitch) if width > 0 and pitch > 0 else 1.0
        return replace(self, clearance=self.clearance * share)


LONE_AREA_RANGE = (0.0, 25.0)
"""Bounds of :attr:`LinkOptions.lone_area`, square pitches (the one place they are set): at 25, a
lone run five pitches long at five pitches wide, beyond any stub."""


def _rim(region: Region, band: Region | None, depth: float) -> Region:
    """The region whose edge the boundary links follow: ``region`` less the part of ``band`` (the
    engine's, :attr:`loadpath.toolpath.Toolpaths.band`) that lies more than ``depth`` mm inside it."""
    if band is None or band.is_empty or depth < 0:
        return region
    deep = band.intersection(region.buffer(-depth))
    return region if deep.is_empty else region.difference(deep)


def _own_reach(
    region: Region, e_pt: Points2, e_dir: Points2, edge_d: np.ndarray, pitch: float, options: LinkOptions
) -> np.ndarray:
    """How far along its own path a link from each end may come near that path, mm (2 n,).

    Two pitches, and at an end that meets the edge at a shallow angle ``a`` as far as the link
    along the edge stays within the clearance of the path converging on it (``clearance / sin a``
    and a pitch), at most ``options.wedge`` pitches (0: two pitches everywhere).
    """
    own = np.full(len(e_pt), 2.0 * pitch)
    if options.wedge <= 2.0:
        return own
    near = np.flatnonzero(edge_d <= options.edge_reach * pitch)
    if not len(near):
        return own
    foot = shapely.get_coordinates(shapely.shortest_line(region.boundary, shapely.points(e_pt[near])))[0::2]
    nrm = e_pt[near] - foot
    nrm /= np.maximum(np.hypot(*nrm.T), 1e-12)[:, None]
    sin_a = np.abs(np.einsum("ij,ij->i", nrm, e_dir[near]))
    reach = (options.clearance / np.maximum(sin_a, 1e-3) + 1.0) * pitch
    own[near] = np.clip(reach, 2.0 * pitch, options.wedge * pitch)
    return own


def _root(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def _segment_samples(p0: Points2, p1: Points2, step: float) -> tuple[Points2, np.ndarray]:
    """Points from each ``p0[i]`` towards ``p1[i]`` (k, 2), at most ``step`` apart, far ends left out.

    Returns the points (m, 2), segment by segment, and each segment's count (k,) int: the one
    sampling rule of the links' clearance tests (:func:`_polyline_samples`).
    """
    dv = p1 - p0
    n = np.maximum(1, np.ceil(np.hypot(dv[:, 0], dv[:, 1]) / step).astype(np.int64))
    rep = np.repeat(np.arange(len(n)), n)
    k = np.arange(len(rep)) - np.repeat(np.cumsum(n) - n, n)
    return p0[rep] + (k / n[rep])[:, None] * dv[rep], n


def _polyline_samples(points: Points2, at: np.ndarray, step: float) -> tuple[Points2, np.ndarray]:
    """Points along many polylines at most ``step`` apart (vertices included): the polylines'
    ``points`` (m, 2) back to back, polyline ``i`` from ``at[i]`` to ``at[i + 1]`` (c + 1,) int, each
    of two points or more.

    Returns the samples (s, 2), polyline after polyline (each segment's :func:`_segment_samples`,
    then the polyline's last vertex), and where each polyline's start (c + 1,) int.
    """
    seg = np.ones(max(len(points) - 1, 0), dtype=bool)
    seg[at[1:-1] - 1] = False  # no segment from one polyline's last vertex to the next one's first
    inner, n = _segment_samples(points[:-1][seg], points[1:][seg], step)
    per = np.bincount(np.repeat(np.arange(len(at) - 1), np.diff(at) - 1), weights=n, minlength=len(at) - 1)
    total = per.astype(np.int64) + 1  # and the last vertex
    last = np.cumsum(total) - 1
    out = np.zeros((int(total.sum()), 2))
    out[last] = points[at[1:] - 1]
    rest = np.ones(len(out), dtype=bool)
    rest[last] = False
    out[rest] = inner
    return out, np.concatenate([[0], last + 1])


def _samples(points: Points2, step: float) -> Points2:
    """Points along a polyline at most ``step`` apart (vertices included): one polyline's
    :func:`_polyline_samples`, without the bookkeeping of many."""
    out, _ = _segment_samples(points[:-1], points[1:], step)
    return np.vstack([out, points[-1:]])


def _edge_limit(options: LinkOptions, pitch: float) -> float:
    """The longest boundary link, mm (never shorter than the longest straight one)."""
    return max(options.max_edge_link, options.max_link) * pitch


def _sample_step(pitch: float) -> float:
    """How far apart a link's and a path's clearance samples lie, mm (a quarter pitch)."""
    return 0.25 * pitch


def _rounded(pt: np.ndarray) -> tuple:
    """An end point as ``stats["link_ends"]`` names it (to 1e-9 mm)."""
    return tuple(np.round(pt, 9).tolist())


def _length(pts: Points2) -> float:
    """Length of a polyline (n, 2), mm."""
    return float(np.sum(np.hypot(*np.diff(pts, axis=0).T)))


def _clear_reach(options: LinkOptions, pitch: float) -> float:
    """Within what distance of a link's sample a path's or another link's sample is too near, mm:
    the clearance less half a sampling step (an eighth of a pitch)."""
    return options.clearance * pitch - 0.5 * _sample_step(pitch)


def link_paths(
    paths: Sequence[Path],
    region: Region,
    pitch: float,
    options: LinkOptions = LinkOptions(),
    field: object | None = None,
    band: Region | None = None,
) -> tuple[tuple[Path, ...], dict]:
    """Link paths end to end into runs (module docstring; ``options.grow_chains`` None: both ways,
    the fewer runs kept, the grown ones on a tie), then through cuts (:mod:`loadpath.engines.cuts`).

    ``field`` (the followed StressField, optional) keeps the cuts where the paths carry little
    (``options.cut_stress``).  ``band`` (the engine's :attr:`loadpath.toolpath.Toolpaths.band`,
    optional): its edge, where deeper than ``options.band_depth`` inside the region, is linked along
    as the region's is.  Each round of cuts relinks the cut paths, the links laid before
    first (so the rest of the layer keeps its links), and is kept only when it leaves fewer groups
    of runs that travels under ``free_hop`` do not join, and no more runs (``stats["cuts"]`` counts
    the cuts kept); the rest as :func:`_link_layer`.
    """
    runs, stats = _link_layer(paths, region, pitch, options, band=band)
    stats["cuts"] = 0
    if options.cut_reach <= 0 or len(runs) < 3:
        stats.pop("kept_paths", None)
        stats.pop("link_ends", None)
        return runs, stats
    ps = stats.pop("kept_paths")
    for _ in range(options.cut_rounds):
        cut, n, touched = cut_paths(
            ps,
            runs,
            pitch,
            options.cut_reach,
            options.cut_gap,
            options.cut_cross,
            hop=options.free_hop,
            field=field,
            stress_share=options.cut_stress,
        )
        if not n:
            break
        only = set(map(tuple, np.round(touched, 9).tolist()))
        runs2, stats2 = _link_layer(
            cut, region, pitch, replace(options, min_fragment=0.0), stats.get("link_ends", ()), only, band
        )
        hop = options.free_hop
        if hop_groups(runs2, hop) >= hop_groups(runs, hop) or len(runs2) > len(runs):
            break
        ps = stats2.pop("kept_paths")
        stats2["cuts"] = stats["cuts"] + n
        stats2["paths_in"], stats2["dropped"] = stats["paths_in"], stats["dropped"]
        runs, stats = runs2, stats2
    stats.pop("kept_paths", None)
    stats.pop("link_ends", None)
    return runs, stats


def hop_groups(runs: Sequence[Path], hop: float) -> int:
    """How many groups the runs form when ends less than ``hop`` mm apart join them: the fewest
    retracted travels (plus one) a print order can make of them."""
    if not runs:
        return 0
    from scipy.spatial import cKDTree

    from loadpath.engines.cuts import free_ends

    ends = free_ends(runs)
    parent = list(range(len(runs)))
    for a, b in cKDTree(ends).query_pairs(hop, output_type="ndarray") if hop > 0 else []:
        ra, rb = _root(parent, int(a) // 2), _root(parent, int(b) // 2)
        if ra != rb:
            parent[ra] = rb
    return len({_root(parent, i) for i in range(len(runs))})


def _link_layer(
    paths: Sequence[Path],
    region: Region,
    pitch: float,
    options: LinkOptions,
    prefer: Sequence[tuple] = (),
    only: set | None = None,
    band: Region | None = None,
) -> tuple[tuple[Path, ...], dict]:
    """One linking of a layer's paths (:func:`link_paths` without cuts; ``prefer``, ``only`` as
    :func:`_link`).

    Both ways share the fragments dropped, the ends, the samples and their trees, the candidate
    links and each candidate's geometric test (:class:`_Layer`): only the order in which the
    candidates are tried differs between them.

    Parameters
    ----------
    paths : sequence of Path
    region : Polygon or MultiPolygon, mm
        The replace region: links stay inside it.
    pitch : float, mm
        Nominal pitch (unit of the options' lengths).
    options : LinkOptions

    Returns
    -------
    runs : tuple of Path
        The linked runs (a run's ``kind`` is ``"continuous"`` when any of its paths is).
    stats : dict
        ``links``, ``boundary_links``, ``link_mm``, ``paths_in``, ``runs``, ``dropped`` (fragments),
        ``rejected_loop`` / ``rejected_geometry`` / ``rejected_links`` (candidates refused: the
        link would close a loop; leaves the region, turns back or comes near another path; comes
        near a link laid before), ``lone_dropped`` (runs left without a link and smaller than
        ``lone_area``, :func:`drop_lone`) and ``links_at`` (per run: the vertex ranges of its links,
        for :func:`pieces`).
    """
    ps = [p for p in paths if len(p.points) >= 2]
    stats: dict = {"paths_in": len(ps), "links": 0, "boundary_links": 0, "link_mm": 0.0, "dropped": 0}
    if options.min_fragment > 0:
        ps, dropped = drop_fragments(ps, options.min_fragment * pitch, options.fragment_share)
        stats["dropped"] = dropped
    layer = _Layer.of(ps, region, pitch, options, band) if len(ps) >= 2 else None
    if layer is None:
        runs, spans = tuple(ps), [[] for _ in ps]
    else:
        if options.grow_chains is not None:
            runs, stats = _link(layer, options.grow_chains, dict(stats), prefer, only)
        else:
            grown = _link(layer, True, dict(stats), prefer, only)
            first = _link(layer, False, dict(stats), prefer, only)
            base = stats
            runs, stats = grown if len(grown[0]) <= len(first[0]) else first
            if options.exact > 0 and len(runs) > 1 and only is None and not prefer:
                chosen = exact_links(layer, options.exact, options.exact_integers)
                if chosen:
                    exact = _link(layer, True, dict(base), chosen, None)
                    if len(exact[0]) < len(runs):
                        runs, stats = exact
                        stats["exact"] = 1
        spans = stats["links_at"]
    keep = drop_lone(runs, spans, options.lone_area * pitch * pitch, options.lone_share)
    stats["lone_dropped"] = int(len(runs) - keep.sum())
    runs = tuple(r for r, k in zip(runs, keep, strict=True) if k)
    if layer is not None:
        stats["links_at"] = [s for s, k in zip(spans, keep, strict=True) if k]
    stats["runs"] = len(runs)
    stats["kept_paths"] = ps
    return runs, stats


def _end_pairs(
    e_pt: Points2, e_dir: Points2, ends: np.ndarray, reach: float, max_turn: float, grown: Region
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Pairs of ``ends`` (indices into ``e_pt``) of different paths within ``reach`` mm: the
    candidates of straight and boundary links.

    Returns ``a, b`` (c,) int, ``gap`` (c,) float mm (their straight distance), ``facing`` (c,)
    bool (the straight link leaves both ends at most ``max_turn`` degrees off their outward
    directions ``e_dir``) and ``inside`` (c,) bool (a facing pair's straight link lies inside
    ``grown``, a prepared region); None when no two of the ends lie within reach.
    """
    from scipy.spatial import cKDTree

    if len(ends) < 2:
        return None
    fp = cKDTree(e_pt[ends]).query_pairs(reach, output_type="ndarray")
    if not len(fp):
        return None
    a, b = ends[fp[:, 0]], ends[fp[:, 1]]
    keep = (a // 2) != (b // 2)
    a, b = a[keep], b[keep]
    v = e_pt[b] - e_pt[a]
    gap = np.hypot(*v.T)
    u = v / np.maximum(gap, 1e-12)[:, None]
    cos_t = np.cos(np.radians(max_turn))
    facing = (np.sum(e_dir[a] * u, axis=1) >= cos_t) & (np.sum(-e_dir[b] * u, axis=1) >= cos_t)
    inside = np.zeros(len(a), dtype=bool)
    if facing.any():
        k = np.flatnonzero(facing)
        inside[k] = shapely.covers(grown, shapely.linestrings(np.stack([e_pt[a[k]], e_pt[b[k]]], axis=1)))
    return a, b, gap, facing, inside


@dataclass
class _Layer:
    """One layer's paths prepared for linking: what both ways of :func:`link_paths` share.

    Attributes
    ----------
    ps : list of Path
        The paths (fragments dropped), ``n`` of them.
    region, grown : Polygon or MultiPolygon, mm
        The region less the band deep inside it (:func:`_rim`: the edges the boundary links follow),
        and the whole region grown by 1 µm (prepared: the links' containment test).
    pitch : float, mm
    options : LinkOptions
    e_pt, e_dir : (2 n, 2) float, mm and unit
        Ends (``2 i`` the head of path ``i``, ``2 i + 1`` its tail) and their outward directions.
    e_w : (2 n,) float, mm
        The pitch at each end.
    edge_d : (2 n,) float, mm
        Distance of each end to the region's edge.
    tree : cKDTree
        Samples of every path (every quarter pitch) ...
    s_pid, s_arc : (m,) int and float, mm
        ... their path and arc length from its head;
    p_len : (n,) float, mm
        the paths' lengths (of the samples).
    a, b : (c,) int
        Candidate links' ends, ...
    gap : (c,) float, mm
        ... their straight length, ...
    straight, near_edge : (c,) bool
        ... whether the straight link is a candidate (short, not turning back, inside the region)
        and whether both ends are near the edge (a boundary link is a candidate);
    order : (k,) int
        the candidates, shortest first.
    region_key : bytes
        ``region``'s WKB: what names its shrunk rings (:func:`loadpath.engines.edge_links.shrunk_rings`).
    tried : dict
        ``(ea, eb, straight_ok, edge_ok)`` -> the link's points, their samples and whether it is a
        boundary link, or None: the geometric test of a candidate does not depend on the links laid
        before it, so each is made once for both ways.
    straight_links : dict or None
        The straight candidates' points, samples and clearance, both ways, all made at the first
        straight link tried (:meth:`_straight_links`).
    edge_links : dict or None
        The boundary candidates' points, samples and containment, both ways, all made at the first
        boundary link tried (:meth:`_edge_links`).
    """

    ps: list[Path]
    region: Region
    grown: Region
    pitch: float
    options: LinkOptions
    e_pt: np.ndarray
    e_dir: np.ndarray
    e_w: np.ndarray
    edge_d: np.ndarray
    tree: object
    s_pid: np.ndarray
    s_arc: np.ndarray
    p_len: np.ndarray
    a: np.ndarray
    b: np.ndarray
    gap: np.ndarray
    straight: np.ndarray
    near_edge: np.ndarray
    order: np.ndarray
    region_key: bytes
    tried: dict
    e_own: np.ndarray | None = None
    straight_links: dict | None = None
    edge_links: dict | None = None

    @classmethod
    def of(
        cls, ps: list[Path], region: Region, pitch: float, options: LinkOptions, band: Region | None = None
    ) -> _Layer | None:
        """Prepare ``ps`` (at least two paths; ``band`` as :func:`link_paths`); None when no two ends
        lie close enough to link."""
        from scipy.spatial import cKDTree  # here: a run whose links come from the cache never loads scipy

        n = len(ps)
        limit = options.max_link * pitch
        edge_limit = _edge_limit(options, pitch)
        # ends: 2 i = head of path i, 2 i + 1 = its tail; outward direction from a point ~ half a pitch in
        e_pt = np.empty((2 * n, 2))
        e_dir = np.empty((2 * n, 2))
        e_w = np.empty(2 * n)
        for i, p in enumerate(ps):
            q = p.points
            for side, (tip, j) in enumerate(((q[0], 1), (q[-1], len(q) - 2))):
                cum = np.hypot(*(q - tip).T)
                far = np.flatnonzero(cum >= 0.5 * pitch)
                ref = q[far[0] if side == 0 else far[-1]] if len(far) else q[j]
                v = tip - ref
                e_pt[2 * i + side] = tip
                e_dir[2 * i + side] = v / max(float(np.hypot(*v)), 1e-12)
                e_w[2 * i + side] = p.pitch[0] if side == 0 else p.pitch[-1]
        # every path densely sampled, for the clearance test
        samp = [_samples(p.points, _sample_step(pitch)) for p in ps]
        s_pid = np.repeat(np.arange(n), [len(s) for s in samp])
        # unbalanced, not compacted: built several times faster, the same points within reach
        tree = cKDTree(np.concatenate(samp), balanced_tree=False, compact_nodes=False)
        shapely.prepare(region)
        grown = region.buffer(1e-3)
        shapely.prepare(grown)
        found = _end_pairs(e_pt, e_dir, np.arange(2 * n), edge_limit, options.max_turn, grown)
        if found is None:
            return None
        a, b, gap, straight_dir, straight_in = found
        rim = _rim(region, band, options.band_depth * pitch)
        edge_d = shapely.distance(rim.boundary, shapely.points(e_pt))
        # arc length of every sample from its path's head, and the path lengths: a link may come near
        # its own two paths only within ``own`` of the ends it joins (a link that turns back runs
        # alongside its own path otherwise)
        s_arc = np.concatenate(
            [np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(x, axis=0).T))]) for x in samp]
        )
        p_len = np.array([float(np.sum(np.hypot(*np.diff(x, axis=0).T))) for x in samp])
        near_edge = (edge_d[a] <= options.edge_reach * pitch) & (edge_d[b] <= options.edge_reach * pitch)
        e_own = _own_reach(rim, e_pt, e_dir, edge_d, pitch, options)
        straight_dir &= gap <= limit
        candidates = np.flatnonzero((straight_dir & straight_in) | near_edge)
        order = candidates[np.argsort(gap[candidates], kind="stable")]
        return cls(
            ps, rim, grown, pitch, options, e_pt, e_dir, e_w, edge_d, tree, s_pid, s_arc, p_len,
            a, b, gap, straight_dir & straight_in, near_edge, order, shapely.to_wkb(rim), {}, e_own,
        )

    def clear_of_paths(self, s: Points2, ea: int, eb: int) -> bool:
        """Whether samples ``s`` of a link from end ``ea`` to ``eb`` keep the clearance from every path.

        Its own two paths count only beyond ``2 pitch`` of the ends it joins (:meth:`_exempt`; the
        test of one link, :meth:`_clear` of many).
        """
        hits = self.tree.query_ball_point(s, _clear_reach(self.options, self.pitch))
        found = [h for h in hits if h]
        if not found:
            return True
        h = np.concatenate(found)
        return not bool(np.any(~self._exempt(h, ea) & ~self._exempt(h, eb)))

    def _clear(self, s: Points2, at: np.ndarray, ea: np.ndarray, eb: np.ndarray) -> np.ndarray:
        """Whether each link ``i``, from end ``ea[i]`` to ``eb[i]`` (c,) int, keeps the clearance
        from every path: its samples ``s[at[i] : at[i + 1]]`` ((m, 2) mm; ``at`` (c + 1,) int), all
        of them in one tree query, its own ends' exemptions as arrays (:meth:`_exempt`).

        Returns (c,) bool.
        """
        from scipy.spatial import cKDTree

        # every (path sample, link sample) pair within reach as arrays: the pairs query_ball_point
        # finds (the same distance test), without a Python list per sample (half the time)
        pairs = self.tree.sparse_distance_matrix(
            cKDTree(s), _clear_reach(self.options, self.pitch), output_type="ndarray"
        )
        h = pairs["i"].astype(np.int64)
        c = np.repeat(np.arange(len(ea)), np.diff(at))[pairs["j"]]
        bad = ~self._exempt(h, ea[c]) & ~self._exempt(h, eb[c])
        clear = np.ones(len(ea), dtype=bool)
        clear[c[bad]] = False
        return clear

    def _straight_links(self) -> dict[tuple[int, int], tuple]:
        """Every straight candidate link, both ways: ``(ea, eb) -> (i, lo, hi, clear, samples)``, its
        samples ``samples[lo:hi]`` and whether it is clear of the paths.

        All sampled and tested against the paths at once (:meth:`_clear`): the same samples as
        :func:`_samples` and the same test as :meth:`clear_of_paths`.
        """
        ks = np.flatnonzero(self.straight)
        ea = np.concatenate([self.a[ks], self.b[ks]])
        eb = np.concatenate([self.b[ks], self.a[ks]])
        return self._straight_batch(ea, eb)

    def _straight_batch(self, ea: np.ndarray, eb: np.ndarray) -> dict[tuple[int, int], tuple]:
        """The straight links from end ``ea[i]`` to ``eb[i]`` (c,) int, sampled and tested against
        the paths at once: ``(ea, eb) -> (i, lo, hi, clear, samples)`` as :meth:`_straight_links`."""
        if not len(ea):
            return {}
        ends_xy = np.stack([self.e_pt[ea], self.e_pt[eb]], axis=1).reshape(-1, 2)
        pts, at = _polyline_samples(ends_xy, np.arange(0, 2 * len(ea) + 1, 2), _sample_step(self.pitch))
        clear = self._clear(pts, at, ea, eb)
        ends = at.tolist()
        return {
            (x, y): (i, ends[i], ends[i + 1], ok, pts)
            for i, (x, y, ok) in enumerate(zip(ea.tolist(), eb.tolist(), clear.tolist(), strict=True))
        }

    def prepare_straight(self, ea: np.ndarray, eb: np.ndarray) -> None:
        """Sample and test the straight links ``ea[i] -> eb[i]`` not tried yet in one batch, so that
        :meth:`geometry` finds them made (the same samples and test as one at a time)."""
        if self.straight_links is None:
            self.straight_links = self._straight_links()
        known = self.straight_links
        new = [(x, y) for x, y in zip(ea.tolist(), eb.tolist(), strict=True) if (x, y) not in known]
        if new:
            xs, ys = (np.array(v, dtype=np.int64) for v in zip(*new, strict=True))
            known.update(self._straight_batch(xs, ys))

    def _edge_links(
        self, ea: np.ndarray | None = None, eb: np.ndarray | None = None
    ) -> dict[tuple[int, int], tuple | None]:
        """Boundary links from end ``ea[i]`` to ``eb[i]`` (default: every boundary candidate, both
        ways): ``(ea, eb) -> (points, samples, inside)``, or None where the ring piece does not exist.

        Each link on the region's edge shrunk by its ends' mean distance to it (at most the edge
        reach; rounded to 0.01 mm), all of them at once
        (:func:`loadpath.engines.edge_links.ring_pieces`), then sampled as :func:`_samples` and
        tested for lying inside the (grown) region together.
        """
        if ea is None or eb is None:
            ks = np.flatnonzero(self.near_edge)
            ea, eb = np.concatenate([self.a[ks], self.b[ks]]), np.concatenate([self.b[ks], self.a[ks]])
        o, pitch = self.options, self.pitch
        inset = np.clip(0.5 * (self.edge_d[ea] + self.edge_d[eb]), 0.0, o.edge_reach * pitch)
        keys, g = np.unique([round(float(x), 2) for x in inset], return_inverse=True)
        if not len(keys):
            return {}
        rings, groups = Rings.concat([shrunk_rings(self.region, float(k), self.region_key) for k in keys])
        pts, at, exists = ring_pieces(rings, groups, g, self.e_pt, ea, eb, _edge_limit(o, pitch))
        ok = np.flatnonzero(exists)
        out: dict[tuple[int, int], tuple | None] = dict.fromkeys(zip(ea.tolist(), eb.tolist(), strict=True))
        if not len(ok):
            return out
        at = np.append(at[ok], len(pts))
        s, s_at = _polyline_samples(pts, at, _sample_step(pitch))
        lines = shapely.linestrings(pts, indices=np.repeat(np.arange(len(ok)), np.diff(at)))
        inside = shapely.covers(self.grown, lines)
        at, s_at = at.tolist(), s_at.tolist()
        for j, (x, y) in enumerate(zip(ea[ok].tolist(), eb[ok].tolist(), strict=True)):
            out[(x, y)] = (pts[at[j] : at[j + 1]], s[s_at[j] : s_at[j + 1]], bool(inside[j]))
        return out

    def _exempt(self, h: np.ndarray, e: int | np.ndarray) -> np.ndarray:
        """Which sample hits ``h`` lie on the path of end ``e`` (one end, or one per hit) within
        ``2 pitch`` of that end: a link may touch its own paths there."""
        pid = e // 2
        d = np.where(e % 2 == 0, self.s_arc[h], self.p_len[pid] - self.s_arc[h])
        return (self.s_pid[h] == pid) & (d <= self.e_own[e])

    def forward(self, pts: Points2, ea: int, eb: int) -> bool:
        """Whether a link leaves each end at most ``max_turn`` off its direction."""
        cos_t = np.cos(np.radians(self.options.max_turn))
        d0, d1 = pts[1] - pts[0], pts[-2] - pts[-1]
        n0, n1 = np.hypot(*d0), np.hypot(*d1)
        return bool(
            (n0 < 1e-9 or float(self.e_dir[ea] @ d0) / n0 >= cos_t)
            and (n1 < 1e-9 or float(self.e_dir[eb] @ d1) / n1 >= cos_t)
        )

    def geometry(
        self, ea: int, eb: int, straight_ok: bool, edge_ok: bool
    ) -> tuple[Points2, Points2, bool] | None:
        """The link from end ``ea`` to ``eb`` that passes the geometric tests, or None (memoised).

        The straight one when ``straight_ok`` and it is clear of the paths, else the boundary link
        when ``edge_ok`` and it turns, measures, stays inside and keeps clear as the module docstring
        says.  Returns its points, their samples (every quarter pitch) and whether it is a boundary
        link.
        """
        key = (ea, eb, straight_ok, edge_ok)
        if key in self.tried:
            return self.tried[key]
        pitch, e_pt = self.pitch, self.e_pt
        out = None
        if straight_ok:
            if self.straight_links is None:
                self.straight_links = self._straight_links()
            known = self.straight_links.get((ea, eb))
            if known is not None:
                _, lo, hi, ok, pts = known
                if ok:
                    out = (np.vstack([e_pt[ea], e_pt[eb]]), pts[lo:hi], False)
            else:  # a long link of the second pass
                cand = np.vstack([e_pt[ea], e_pt[eb]])
                s = _samples(cand, _sample_step(pitch))
                if self.clear_of_paths(s, ea, eb):
                    out = (cand, s, False)
        if out is None and edge_ok:
            if self.edge_links is None:
                self.edge_links = self._edge_links()
            if (ea, eb) not in self.edge_links:  # not a candidate (a link laid before cuts)
                self.edge_links.update(self._edge_links(np.array([ea]), np.array([eb])))
            known = self.edge_links[(ea, eb)]
            if known is not None:
                cand, s, inside = known
                if (
                    inside
                    and self.forward(cand, ea, eb)
                    and float(np.sum(np.hypot(*np.diff(cand, axis=0).T))) <= _edge_limit(self.options, pitch)
                    and self.clear_of_paths(s, ea, eb)
                ):
                    out = (cand, s, True)
        self.tried[key] = out
        return out


class _Laid:
    """Samples of the links laid so far, for the clearance between links: is a sample within
    ``reach`` of one of them.

    A tree of most of them, rebuilt only when the recent ones reach ``batch`` samples; the recent
    ones are asked the other way round, as queries into a tree of the new link's few samples (the
    same pairs within reach: the distance of two points does not depend on which is the query, and a
    tree's search finds every pair within reach).  Rebuilding one tree of all of them at every link
    laid was a tenth of the linking's time.
    """

    def __init__(self, reach: float, batch: int = 64) -> None:
        self.reach = reach
        self.batch = batch
        self.old: list[Points2] = []
        self.tree = None
        self.recent: list[Points2] = []
        self.n_recent = 0
        self._recent_pts: Points2 | None = None

    def near(self, s: Points2) -> bool:
        """Whether any of the samples ``s`` (m, 2) lies within ``reach`` of a laid one."""
        from scipy.spatial import cKDTree

        if self.tree is not None and self.tree.query_ball_point(s, self.reach, return_length=True).any():
            return True
        if not self.recent:
            return False
        if self._recent_pts is None:
            self._recent_pts = np.concatenate(self.recent)
        return bool(cKDTree(s).query_ball_point(self._recent_pts, self.reach, return_length=True).any())

    def add(self, s: Points2) -> None:
        """Lay the samples of one more link."""
        from scipy.spatial import cKDTree

        self.recent.append(s)
        self.n_recent += len(s)
        self._recent_pts = None
        if self.n_recent >= self.batch:
            self.old.extend(self.recent)
            self.tree = cKDTree(np.concatenate(self.old), balanced_tree=False, compact_nodes=False)
            self.recent, self.n_recent = [], 0


def _link(
    layer: _Layer, grow_chains: bool, stats: dict, prefer: Sequence[tuple] = (), only: set | None = None
) -> tuple[tuple[Path, ...], dict]:
    """Link a prepared layer's paths one way: chains grown end by end (``grow_chains``) or all
    candidates shortest first; ``stats`` is filled in (see :func:`link_paths`).

    ``prefer``: links of an earlier linking, ``(end point, end point, boundary)`` each, laid first
    where both ends are still there and the link still passes its tests (the relinking after
    cuts keeps the layer's other links as they were); ``only`` (rounded end points): no new link
    but between two of these ends (the ends of the cuts), so the rest of the layer stays as it was.
    """
    ps, options, pitch = layer.ps, layer.options, layer.pitch
    n = len(ps)
    a, b, e_pt, e_dir = layer.a, layer.b, layer.e_pt, layer.e_dir
    used = np.zeros(2 * n, dtype=bool)
    parent = list(range(n))
    link: dict[int, tuple[int, Points2]] = {}  # end -> (other end, link points from this end)
    laid = _Laid(_clear_reach(options, pitch))
    samples: dict[tuple[int, int], Points2] = {}  # each link's samples (for the insertions)

    def accept(ea: int, eb: int, straight_ok: bool, edge_ok: bool) -> bool:
        if used[ea] or used[eb] or (allowed is not None and not (allowed[ea] and allowed[eb])):
            return False
        pa, pb = ea // 2, eb // 2
        ra, rb = _root(parent, pa), _root(parent, pb)
        if ra == rb:
            stats["rejected_loop"] = stats.get("rejected_loop", 0) + 1
            return False
        found = layer.geometry(ea, eb, straight_ok, edge_ok)
        if found is None:
            stats["rejected_geometry"] = stats.get("rejected_geometry", 0) + 1
            return False
        pts, s, boundary = found
        if laid.near(s):  # not clear of the links laid so far
            stats["rejected_links"] = stats.get("rejected_links", 0) + 1
            return False
        laid.add(s)
        samples[(min(ea, eb), max(ea, eb))] = s
        stats.setdefault("link_ends", []).append(
            (_rounded(e_pt[ea]), _rounded(e_pt[eb]), bool(boundary))
        )
        used[ea] = used[eb] = True
        parent[ra] = rb
        link[ea] = (eb, pts)
        link[eb] = (ea, pts[::-1])
        stats["links"] += 1
        stats["boundary_links"] += int(boundary)
        stats["link_mm"] += _length(pts)
        return True

    allowed = None
    if prefer:
        at = {q: e for e, q in enumerate(map(tuple, np.round(e_pt, 9).tolist()))}
        for p0, p1, boundary in prefer:
            ea, eb = at.get(p0), at.get(p1)
            if ea is not None and eb is not None:
                accept(ea, eb, not boundary, boundary)
    if only is not None:
        allowed = np.array([q in only for q in map(tuple, np.round(e_pt, 9).tolist())], dtype=bool)

    if grow_chains:

        def try_link(k: int, ea: int, eb: int) -> bool:
            return accept(ea, eb, bool(layer.straight[k]), bool(layer.near_edge[k]))

        _grow(layer.order, a, b, 2 * n, used, link, try_link)
    else:
        for k in layer.order:
            accept(int(a[k]), int(b[k]), bool(layer.straight[k]), bool(layer.near_edge[k]))

    # second pass: the ends still free, by longer straight links through what is left empty
    if options.max_long_link > options.max_link:
        free = np.flatnonzero(~used)
        found = _end_pairs(e_pt, e_dir, free, options.max_long_link * pitch, options.max_turn, layer.grown)
        if found is not None:
            fa, fb, fg, facing, inside = found
            ok = facing & inside
            fa, fb, fg = fa[ok], fb[ok], fg[ok]
            order = np.argsort(fg, kind="stable")
            # in batches of the next pairs whose ends are still free: their samples and clearance
            # made at once (one tree query; one per link was a third of a sparse layer's linking)
            for lo in range(0, len(order), _LONG_BATCH):
                ks = order[lo : lo + _LONG_BATCH]
                free_k = ks[~used[fa[ks]] & ~used[fb[ks]]]
                layer.prepare_straight(fa[free_k], fb[free_k])
                for k in ks:
                    accept(int(fa[k]), int(fb[k]), True, False)

    if options.insert and allowed is None:  # (a relinking after cuts keeps the rest of the layer)
        from loadpath.engines.insertion import insert_runs

        insert_runs(layer, link, used, parent, samples, stats)
    runs, spans = _walk(ps, link, layer.e_w, options.link_width)
    stats["runs"] = len(runs)
    stats["links_at"] = spans
    return tuple(runs), stats


_LONG_BATCH = 64
"""Long links of the second pass sampled and tested for clearance together
(:meth:`_Layer.prepare_straight`)."""


def _grow(
    order: np.ndarray, a: np.ndarray, b: np.ndarray, n_ends: int, used: np.ndarray, link: dict, try_link
) -> None:
    """Grow chains one link at a time, the way a slicer chains its infill lines.

    Each chain starts at the free end with the fewest candidate links (a zig-zag's corner) and
    leaves by its path's other end; from the end it leaves by, it takes the shortest candidate
    link that ``try_link(k, end, other)`` accepts, enters that path, leaves by its far end, and so
    on; when no candidate is accepted, the chain grows back from its start.  Taking all candidates
    shortest first instead (``grow_chains = False``) breaks a zig-zag wherever the links of two
    neighbours' near ends and of their far ends are both short: the second closes a loop, and each
    such break costs a run (bench's two-island part, PrusaSlicer 100 %: 9 runs on a layer of 92
    straight paths, where one zig-zag per island suffices).
    """
    cand: list[list[int]] = [[] for _ in range(n_ends)]
    for k in order:  # shortest first
        cand[int(a[k])].append(int(k))
        cand[int(b[k])].append(int(k))

    def far_free(e: int) -> int:
        while e in link:
            e = link[e][0] ^ 1
        return e

    def grow(e: int) -> None:
        while not used[e]:
            for k in cand[e]:
                o = int(b[k]) if int(a[k]) == e else int(a[k])
                if not used[o] and try_link(k, e, o):
                    e = far_free(o ^ 1)
                    break
            else:
                return

    for s in sorted(range(n_ends), key=lambda e: (len(cand[e]), e)):
        if used[s] or not cand[s]:
            continue
        grow(far_free(s ^ 1))
        grow(s)


def _walk(
    ps: list[Path], link: dict[int, tuple[int, Points2]], e_w: np.ndarray, thin: float = 1.0
) -> tuple[list[Path], list]:
    """Chains of paths and links, each from a free end (no loops, so one exists)."""
    n = len(ps)
    done = np.zeros(n, dtype=bool)
    runs: list[Path] = []
    spans: list[list[tuple[int, int]]] = []
    for i in range(n):
        if done[i]:
            continue
        end = 2 * i  # walk off i's head to find a free end of its chain
        while end in link:
            other = link[end][0]
            end = other ^ 1  # the far end of the next path
        # ``end`` is free: the chain starts there, entering its path at ``end``
        pts_c, pit_c, kinds, at = [], [], set(), []
        count = 0
        enter = end
        while True:
            pi = enter // 2
            done[pi] = True
            p = ps[pi]
            q, w = (p.points, p.pitch) if enter % 2 == 0 else (p.points[::-1], p.pitch[::-1])
            pts_c.append(q)
            pit_c.append(w)
            count += len(q)
            kinds.add(p.kind)
            leave = enter ^ 1
            if leave not in link:
                break
            other, lp = link[leave]
            if thin != 1.0:  # the link's own vertices next to its ends carry its narrower pitch
                near_a = lp[0] + 0.02 * (lp[1] - lp[0])
                near_b = lp[-1] + 0.02 * (lp[-2] - lp[-1])
                lp = np.vstack([lp[:1], near_a, lp[1:-1], near_b, lp[-1:]])
            inner = lp[1:-1]
            if len(inner):
                seg = np.hypot(*np.diff(lp, axis=0).T)
                cum = np.cumsum(seg)[:-1] / max(float(seg.sum()), 1e-12)
                pts_c.append(inner)
                pit_c.append(thin * (e_w[leave] + cum * (e_w[other] - e_w[leave])))
            at.append((count - 1, count + len(inner)))  # link segments: vertex count-1 .. next path's first
            count += len(inner)
            enter = other
        pts = np.concatenate(pts_c)
        pit = np.concatenate(pit_c)
        keep = np.r_[True, np.hypot(*np.diff(pts, axis=0).T) > 1e-9]
        if not keep.all():  # a link starting exactly at a vertex: drop the repeat, shift the spans
            idx = np.cumsum(keep) - 1
            at = [(int(idx[x]), int(idx[min(y, len(idx) - 1)])) for x, y in at]
            pts, pit = pts[keep], pit[keep]
        runs.append(Path(pts, pit, "continuous" if "continuous" in kinds else "fill"))
        spans.append(at)
    return runs, spans


def pieces(runs: Sequence[Path], spans: Sequence[Sequence[tuple[int, int]]]) -> list[Path]:
    """Split linked runs back into their paths and their links (each a separate bead).

    For measuring overlap honestly: a metric that unions each path's bead with itself would not
    count where a link's bead lies on the ends it joins.
    """
    out: list[Path] = []
    for r, at in zip(runs, spans, strict=True):
        cuts = [0]
        for x, y in at:
            cuts += [x, y]
        cuts.append(len(r.points) - 1)
        for s, z in zip(cuts[:-1], cuts[1:], strict=True):
            if z > s:
                out.append(Path(r.points[s : z + 1], r.pitch[s : z + 1], r.kind))
    return out


def drop_lone(
    runs: Sequence[Path], spans: Sequence[Sequence], min_area: float, share: float = 1.0
) -> np.ndarray:
    """Which runs to keep (bool per run): not those without a link whose bead is smaller than
    ``min_area`` mm² (length times mean pitch, segment by segment), the smallest first while
    together they hold at most ``share`` of the runs' whole area and of their length.

    A lone stub costs a travel and, beyond ``retract_before_travel``, a retraction, and covers
    next to nothing; a run that took a link joins others and costs nothing of its own.  Where the
    lone pieces are a layer's fill (sparse infill at a wide pitch, where few ends lie within a
    link's reach), the share keeps them: dropped, their plastic is more than volume matching can
    give back, and the block is kept as sliced.  The largest run is always kept.
    """
    keep = np.ones(len(runs), dtype=bool)
    if min_area <= 0 or len(runs) < 2:
        return keep
    area = np.array([r.area for r in runs])
    lone = np.flatnonzero(np.array([not len(s) for s in spans], dtype=bool) & (area < min_area))
    lone = lone[np.argsort(area[lone], kind="stable")]  # the smallest first, within the share
    # the share counts length too: a fixed flow width (sparse infill) extrudes by length, whatever
    # the pitch a stub carries
    length = np.array([r.length for r in runs])
    within = (np.cumsum(area[lone]) <= share * float(area.sum())) & (
        np.cumsum(length[lone]) <= share * float(length.sum())
    )
    lone = lone[within]
    keep[lone] = False
    keep[int(np.argmax(area))] = True
    return keep


def drop_fragments(paths: Sequence[Path], min_length: float, share: float) -> tuple[list[Path], int]:
    """Drop paths shorter than ``min_length`` whose bead mostly lies on other beads.

    A short path costs a travel (and a retraction) like a long one; it earns it only where it
    covers what nothing else does.  Its bead (its local pitch wide) is compared with the union of
    the other beads near it: when less than ``share`` of it is its own, it goes.
    """
    ps = list(paths)
    if not ps:
        return ps, 0
    length = np.array([p.length for p in ps])
    short = np.flatnonzero(length < min_length)
    if not len(short):
        return ps, 0
    lines = shapely.linestrings(
        np.concatenate([p.points for p in ps]), indices=np.repeat(np.arange(len(ps)), [len(p.points) for p in ps])
    )
    radius = np.array([0.5 * float(np.median(p.pitch)) for p in ps])
    beads = shapely.buffer(lines, radius, quad_segs=4)
    tree = shapely.STRtree(beads)
    drop = np.zeros(len(ps), dtype=bool)
    for i in short:
        own = beads[i]
        near = tree.query(own)
        near = near[(near != i) & ~drop[near]]
        if not len(near):
            continue
        # only what lies near the short bead matters: the neighbours cut to its bounds (grown by its
        # radius, so no cut runs along its edge) before the union, a few small pieces where the
        # whole beads are layer-long (the same difference: ``own`` lies inside the box)
        x0, y0, x1, y1 = own.bounds
        r = radius[i]
        box = shapely.box(x0 - r, y0 - r, x1 + r, y1 + r)
        rest = own.difference(shapely.union_all(shapely.intersection(beads[near], box)))
        if rest.area < share * own.area:
            drop[i] = True
    return [p for p, d in zip(ps, drop, strict=True) if not d], int(drop.sum())
