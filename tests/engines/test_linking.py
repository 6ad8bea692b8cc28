"""Path linking (``loadpath.engines.linking``): the fragments dropped and the two ways of linking.

The linking of whole engine layers is checked on real slices in ``tests/pipeline/test_printable.py``;
these tests pin what the speed-ups of issue 17 must keep: the fragment test's definition (a short
bead is dropped when less than ``share`` of it lies outside the union of the other beads) and
that both ways of linking, made from one shared preparation, give what each gives alone.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import shapely
from loadpath.engines.linking import LinkOptions, drop_fragments, link_paths
from loadpath.toolpath import Path
from shapely.geometry import box


def _plate(seed: int) -> list[Path]:
    """Long straight paths a pitch apart across a 20 x 10 mm plate, and short pieces scattered
    over them (some on a bead, some between two, some in a gap left by a missing long path)."""
    rng = np.random.default_rng(seed)
    w = 0.45
    paths = [
        Path(np.array([[x, 0.2], [x, 5.0], [x, 9.8]]), np.full(3, w), "fill")
        for k, x in enumerate(0.225 + w * np.arange(44))
        if k not in (10, 11, 30)
    ]
    for _ in range(60):
        x, y = rng.uniform(0.5, 19.5), rng.uniform(0.5, 8.5)
        a = rng.uniform(0, np.pi)
        n = rng.uniform(0.2, 1.3)
        pts = np.array([[x, y], [x + n * np.cos(a), y + n * np.sin(a)]])
        paths.append(Path(pts, np.full(2, w * rng.uniform(0.8, 1.2)), "fill"))
    return paths


def _dropped_by_definition(paths: list[Path], min_length: float, share: float) -> list[bool]:
    """The fragment test as its docstring states it, with each whole neighbouring bead."""
    beads = [
        shapely.buffer(shapely.LineString(p.points), 0.5 * float(np.median(p.pitch)), quad_segs=4) for p in paths
    ]
    tree = shapely.STRtree(beads)
    drop = [False] * len(paths)
    for i, p in enumerate(paths):
        if p.length >= min_length:
            continue
        near = [j for j in tree.query(beads[i]) if j != i and not drop[j]]
        if near:
            rest = beads[i].difference(shapely.union_all([beads[j] for j in near]))
            drop[i] = rest.area < share * beads[i].area
    return drop


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("share", [0.3, 0.5, 0.8])
def test_fragments_dropped_as_the_definition_says(seed, share):
    paths = _plate(seed)
    kept, n = drop_fragments(paths, 3 * 0.45, share)
    expect = _dropped_by_definition(paths, 3 * 0.45, share)
    assert n == sum(expect) > 0
    assert n < sum(p.length < 3 * 0.45 for p in paths)  # some short pieces cover a gap: kept
    assert [id(p) for p in kept] == [id(p) for p, d in zip(paths, expect, strict=True) if not d]


@pytest.mark.parametrize("seed", [0, 1])
def test_both_ways_give_what_each_way_gives_alone(seed):
    """``grow_chains = None`` prepares the layer once and tries every candidate's geometry once for
    both ways: its runs and counts are those of the way it keeps, linked on its own."""
    paths = _plate(seed)
    region = box(0, 0, 20, 10)
    # without cuts (``loadpath.engines.cuts``), which relink the layer after either way
    both = link_paths(paths, region, 0.45, LinkOptions(cut_reach=0))
    grown = link_paths(paths, region, 0.45, LinkOptions(grow_chains=True, cut_reach=0))
    first = link_paths(paths, region, 0.45, LinkOptions(grow_chains=False, cut_reach=0))
    assert len(grown[0]) != len(first[0])  # the two ways differ here: the choice is tested
    best = grown if len(grown[0]) <= len(first[0]) else first
    assert both[1] == best[1]
    assert len(both[0]) == len(best[0])
    for r, s in zip(both[0], best[0], strict=True):
        assert r.kind == s.kind
        np.testing.assert_array_equal(r.points, s.points)
        np.testing.assert_array_equal(r.pitch, s.pitch)


def _zigzag_and_stubs() -> tuple[list[Path], Path, Path]:
    """21 straight paths a pitch apart on the left of a 20 x 10 mm plate (one zig-zag when linked),
    and two stubs on its empty right half, too far from any end to take a link: one of 2 pitches
    (0.41 mm², under the default 5 square pitches, 1.01 mm²) and one of 6 (1.22 mm², over)."""
    w = 0.45
    lines = [Path(np.array([[x, 0.2], [x, 9.8]]), np.full(2, w)) for x in 0.225 + w * np.arange(21)]
    short = Path(np.array([[15.0, 8.0], [15.0 + 2 * w, 8.0]]), np.full(2, w), "fill")
    long = Path(np.array([[15.0, 2.0], [15.0 + 6 * w, 2.0]]), np.full(2, w), "fill")
    return lines, short, long


def test_lone_stubs_under_the_area_are_dropped_linked_runs_kept():
    lines, short, long = _zigzag_and_stubs()
    region = box(0, 0, 20, 10)
    runs, stats = link_paths([*lines, short, long], region, 0.45)
    assert stats["lone_dropped"] == 1
    ends = [tuple(r.points[0]) for r in runs] + [tuple(r.points[-1]) for r in runs]
    assert (15.0, 8.0) not in ends and (15.0 + 0.9, 8.0) not in ends  # the short stub went
    assert any(np.array_equal(r.points, long.points[::-1]) or np.array_equal(r.points, long.points)
               for r in runs)  # the larger one stays
    linked = sum(len(r.points) for r in runs) - len(long.points)
    assert linked >= 2 * len(lines)  # every line still printed, in the zig-zag
    kept, stats0 = link_paths([*lines, short, long], region, 0.45, LinkOptions(lone_area=0.0))
    assert stats0["lone_dropped"] == 0 and len(kept) == len(runs) + 1
    # a bound over the larger stub's area drops it too; the zig-zag is linked, so it stays; the two
    # stubs are 1.7 % of the layer's area, the smaller 0.44 %: the default share (0.5 %) takes it only
    wide = LinkOptions(lone_area=6.5, lone_share=0.02)
    more, stats5 = link_paths([*lines, short, long], region, 0.45, wide)
    assert stats5["lone_dropped"] == 2 and len(more) == len(runs) - 1
    capped, stats_c = link_paths([*lines, short, long], region, 0.45, LinkOptions(lone_area=6.5))
    assert stats_c["lone_dropped"] == 1 and len(capped) == len(runs)


def test_lone_stub_alone_in_its_layer_is_kept():
    _, short, _ = _zigzag_and_stubs()
    runs, stats = link_paths([short], box(0, 0, 20, 10), 0.45)
    assert len(runs) == 1 and stats["lone_dropped"] == 0


@pytest.mark.parametrize("bad", [-0.5, 25.5, float("nan")])
def test_lone_area_bounds(bad):
    from loadpath.engines.linking import LONE_AREA_RANGE
    from loadpath.errors import SettingsError

    assert LONE_AREA_RANGE[0] <= LinkOptions().lone_area <= LONE_AREA_RANGE[1]
    with pytest.raises(SettingsError, match="lone_area"):
        LinkOptions(lone_area=bad)
    with pytest.raises(SettingsError, match="lone_share"):
        LinkOptions(lone_share=1.5)


def test_boundary_piece_is_shapelys_substring_to_the_bit():
    """The linking's own ring pieces (:func:`edge_links.substrings`, many at once from the rings'
    vertices and running lengths) give exactly the points of ``shapely.ops.substring``, so the runs
    stay the same."""
    from loadpath.engines import edge_links
    from shapely.ops import substring

    rng = np.random.default_rng(7)
    poly = shapely.Polygon(
        np.c_[np.cos(np.linspace(0, 2 * np.pi, 97)[:-1]), np.sin(np.linspace(0, 2 * np.pi, 97)[:-1])]
        * (20 + rng.uniform(-1, 1, 96))[:, None]
    )
    rings = edge_links.Rings.of(poly, 0.0)
    ring = rings.rings[0]
    total = ring.length
    # random pieces, a piece from 0, one to the very end, one of zero length, one ending on a vertex
    run = np.r_[0, np.cumsum(np.hypot(*np.diff(shapely.get_coordinates(ring), axis=0).T))]
    cases = [tuple(sorted(rng.uniform(0, total, 2))) for _ in range(200)]
    cases += [(0.0, 5.0), (3.0, total), (7.5, 7.5), (run[10], run[20]), (0.0, total)]
    lo, hi = np.array(cases).T
    pts, at = edge_links.substrings(rings, np.zeros(len(cases), dtype=np.int64), lo, hi)
    for i, (a, b) in enumerate(cases):
        mine = pts[at[i] : at[i + 1]]
        theirs = shapely.get_coordinates(substring(ring, float(a), float(b)))
        assert mine.shape == theirs.shape and np.array_equal(mine, theirs), (a, b)


@pytest.mark.parametrize("seed", [0, 1])
def test_batched_candidate_tests_link_as_one_by_one_on_the_plate(seed):
    """The candidates' tests made in batches (every straight candidate in one tree query, every
    boundary candidate's ring piece, samples and containment at once) give exactly what the tests
    made one link at a time gave (``tests/linking_reference.py``, the code of a57aa31)."""
    from linking_reference import assert_links_as_one_by_one

    laid, passing = assert_links_as_one_by_one(_plate(seed), box(0, 0, 20, 10), 0.45)
    assert laid > 0 and passing > laid


@pytest.mark.parametrize("engine", ["levelset", "swarm"])
def test_batched_candidate_tests_link_engine_layers_as_one_by_one(engine):
    """The same on engine layers of a plate with a hole (the Kirsch field, no FEA): paths that end
    on the outline and on the hole, boundary links on both rings, both ways round."""
    from linking_reference import assert_links_as_one_by_one
    from loadpath.engines import generate
    from loadpath.field import AnalyticField, kirsch_tensor
    from loadpath.toolpath import EngineInput
    from shapely.geometry import Point

    region = box(0, 0, 40, 16).difference(Point(20, 8).buffer(3.0, 64))
    field = AnalyticField(lambda p: kirsch_tensor(p, (20, 8), 3.0, 10.0), region, scale=10.0)
    tp = generate(engine, EngineInput(region, field, 0.45))
    _, passing = assert_links_as_one_by_one(list(tp.paths), region, 0.45)
    assert passing > 0


def test_long_links_tested_in_batches_link_as_one_at_a_time(monkeypatch):
    """The second pass's long links, sampled and tested for clearance in batches of the next pairs
    whose ends are free (_Layer.prepare_straight), give the runs of one test per link as the layer
    makes it without them (_Layer.clear_of_paths), on sparse level-set and swarm layers of a plate
    with a hole (many free ends, some long links not clear)."""
    from loadpath.engines import generate, linking
    from loadpath.engines.linking import link_paths
    from loadpath.field import AnalyticField, kirsch_tensor
    from loadpath.toolpath import EngineInput
    from shapely.geometry import Point

    region = box(0, 0, 40, 16).difference(Point(20, 8).buffer(3.0, 64))
    field = AnalyticField(lambda p: kirsch_tensor(p, (20, 8), 3.0, 10.0), region, scale=10.0)
    real = linking._Layer.prepare_straight
    tested = []

    def counted(self, ea, eb):
        real(self, ea, eb)
        tested.extend(v[3] for k, v in self.straight_links.items() if k in set(zip(ea.tolist(), eb.tolist())))

    for engine in ("levelset", "swarm"):
        paths = list(generate(engine, EngineInput(region, field, 1.6)).paths)
        got = []
        for batch in (counted, lambda self, ea, eb: None):
            monkeypatch.setattr(linking._Layer, "prepare_straight", batch)
            runs, _ = link_paths(paths, region, 1.6)
            got.append([(r.points.tobytes(), r.pitch.tobytes()) for r in runs])
        assert got[0] == got[1], engine
    assert any(tested) and not all(tested)  # long pairs tested in batches, clear and not


def _converging(angle: float = 8.0, w: float = 0.45) -> tuple:
    """Straight paths from the top edge of a 60 x 10 mm plate down onto a band along its middle,
    ``angle`` degrees off it (a bending part's level sets meeting their jump cut): their ends on
    the band lie ``w / sin(angle)`` apart, 7 pitches at 8 degrees."""
    region = box(0, 0, 60, 10)
    band = box(1.0, 4.9, 59.0, 5.1)
    run = (9.8 - 5.1) / np.tan(np.radians(angle))
    step = w / np.sin(np.radians(angle))
    paths = [
        Path(np.array([[x, 9.8], [x + run, 5.1]]), np.full(2, w), "continuous")
        for x in 0.3 + step * np.arange(int((58.2 - run) / step) + 1)
    ]
    return region, band, paths


def test_ends_on_the_engines_band_are_linked_along_it_into_one_zigzag():
    """Issue 19: the level sets end on their jump cut (``Toolpaths.band``) many pitches apart, as
    they end on a bending part's faces; given the band, the linking joins them along it as along
    the edge, and the layer prints as one run instead of one per pair of paths."""
    from loadpath.engines.registry import get as engine_named

    region, band, paths = _converging()
    lo = LinkOptions(**engine_named("levelset").linking)
    alone, _ = link_paths(paths, region, 0.45, lo)
    runs, st = link_paths(paths, region, 0.45, lo, band=band)
    assert len(paths) == 8 and len(alone) == 4 and len(runs) == 1, (len(alone), len(runs))
    assert st["boundary_links"] == st["links"] == len(paths) - 1
    line = shapely.LineString(runs[0].points)
    assert region.buffer(1e-3).covers(line) and line.is_simple
    # the links run along the band's edge, outside it
    assert line.intersection(band.buffer(-0.01)).length < 1e-6
    # a band within ``band_depth`` pitches of the region's edge is not an edge of its own
    near_edge, _ = link_paths(paths, region, 0.45, lo, band=box(0, 0, 60, 0.3))
    assert [r.points.tobytes() for r in near_edge] == [r.points.tobytes() for r in alone]
    off, _ = link_paths(paths, region, 0.45, replace(lo, band_depth=-1.0), band=band)
    assert len(off) == len(alone)


def test_a_run_beside_a_link_laid_before_it_is_inserted_into_that_link():
    """Two paths meet head-on and the greedy pass joins them first (0.4 mm); a third lies a pitch
    beside them, its ends 1.7 mm (3.7 pitches) from theirs, too far for the first pass and with no
    free end left for the second.  The insertion replaces the short link by two through it: one
    run instead of two, crossing nothing, inside the region."""
    w = 0.45
    region = box(0, 0, 20, 2.5)
    a = Path(np.array([[0.3, 1.0], [9.8, 1.0]]), np.full(2, w), "continuous")
    b = Path(np.array([[10.2, 1.0], [19.7, 1.0]]), np.full(2, w), "continuous")
    s = Path(np.array([[8.2, 1.45], [11.8, 1.45]]), np.full(2, w), "fill")
    before, st0 = link_paths([a, b, s], region, w, LinkOptions(insert=False))
    runs, st = link_paths([a, b, s], region, w, LinkOptions())
    assert len(before) == 2 and st0.get("inserted", 0) == 0
    assert len(runs) == 1 and st["inserted"] == 1 and st["links"] == st0["links"] + 1
    np.testing.assert_allclose(
        runs[0].points, [[0.3, 1.0], [9.8, 1.0], [8.2, 1.45], [11.8, 1.45], [10.2, 1.0], [19.7, 1.0]]
    )
    line = shapely.LineString(runs[0].points)
    assert line.is_simple and region.covers(line)


def _fan(seed: int, jitter: float = 0.12) -> list[Path]:
    """A face where level sets spread apart (as at a clamped edge): lines from edge to edge with a
    half-way piece from the left edge into every gap, their ends along the left edge a little
    uneven, so that the shortest links first pair them out of step."""
    rng = np.random.default_rng(seed)
    w, out = 0.45, []
    x = np.linspace(0.12, 29.88, 60)
    for k in range(21):
        y = 0.5 + 0.9 * k
        out.append(Path(np.column_stack([x, np.interp(x, [0, 8, 30], [y + rng.uniform(-jitter, jitter), y, y])]),
                        np.full(60, w)))
        if k < 20:
            xf = np.linspace(0.12, 4.0 + rng.uniform(-0.5, 0.5), 10)
            out.append(Path(np.column_stack([xf, np.full(10, y + 0.45 + rng.uniform(-jitter, jitter))]),
                            np.full(10, w), "fill"))
    return out


def test_two_runs_ending_either_side_of_a_link_along_the_edge_share_it(monkeypatch):
    """Along the left edge the greedy pass pairs the ends out of step (a-b, c alone, d-e, f alone):
    each lone end is a run's.  A swap lays c-d and e-f instead of d-e, joining both runs through the
    link's chain: fewer runs and fewer groups of runs a free hop (1 mm) joins, every path still
    printed once, no run crossing itself or another, all inside the region."""
    import loadpath.engines.insertion as insertion
    from loadpath.engines.linking import hop_groups

    region = box(0, 0, 30, 20)
    paths = _fan(0)
    runs, st = link_paths(paths, region, 0.45, LinkOptions())
    monkeypatch.setattr(insertion, "_swaps", lambda *a, **k: [])
    before, st0 = link_paths(paths, region, 0.45, LinkOptions())
    assert st0.get("swapped", 0) == 0 and st["swapped"] >= 2
    assert len(runs) <= len(before) - 2 and hop_groups(runs, 1.0) < hop_groups(before, 1.0)
    # each link joins two chains (no loop): a swap's extra link is one run fewer
    assert len(runs) == st["paths_in"] - st["dropped"] - st["links"] - st["lone_dropped"]
    lines = [shapely.LineString(r.points) for r in runs]
    assert all(region.covers(g) and g.is_simple for g in lines)
    assert not any(lines[i].intersects(lines[j]) for i in range(len(lines)) for j in range(i))
    every = np.concatenate([r.points for r in runs])
    for p in paths:  # every path's vertices printed (in one run or another, either way)
        assert shapely.distance(shapely.MultiPoint(every), shapely.points(p.points)).max() < 1e-9


@pytest.mark.parametrize("engine, size", [("levelset", (30, 20, 5.0)), ("swarm", (60, 18, 2.5))])
def test_links_chosen_all_at_once_leave_fewer_runs_and_the_same_paths(engine, size):
    """The integer program over every candidate link (``LinkOptions.exact``,
    :mod:`loadpath.engines.exact_links`) on a plate with a hole (the Kirsch field): the greedy ways
    leave 8 (level sets) and 12 (swarm) runs, the program 4 and 9.  Its links use no end twice and
    close no loop, and the runs hold every path the greedy ways kept, crossing nothing, inside."""
    from loadpath import metrics
    from loadpath.engines import generate
    from loadpath.engines.exact_links import exact_links
    from loadpath.engines.linking import _Layer
    from loadpath.engines.registry import get
    from loadpath.field import AnalyticField, kirsch_tensor
    from loadpath.toolpath import EngineInput
    from shapely.geometry import Point

    w, h, r = size
    region = box(0, 0, w, h).difference(Point(w / 2, h / 2).buffer(r, 64))
    field = AnalyticField(lambda p: kirsch_tensor(p, (w / 2, h / 2), r, 10.0), region, scale=10.0)
    tp = generate(engine, EngineInput(region, field, 0.45))
    nodes = 200  # the level-set engine's own (its registry entry); the swarm takes it as an option
    base = replace(replace(LinkOptions(free_hop=1.0), **dict(get(engine).linking)), exact=0)
    assert get("levelset").linking["exact"] == nodes and "exact" not in get("swarm").linking
    greedy, gs = link_paths(list(tp.paths), region, 0.45, base, band=tp.band)
    runs, st = link_paths(list(tp.paths), region, 0.45, replace(base, exact=nodes), band=tp.band)
    assert st["exact"] == 1 and len(runs) < len(greedy), (len(runs), len(greedy))
    assert st["dropped"] == gs["dropped"] and st["lone_dropped"] == gs["lone_dropped"] == 0
    assert metrics.crossings(list(runs)) == 0
    grown = region.buffer(1e-3)
    assert all(grown.covers(shapely.LineString(p.points)) for p in runs)
    paths_mm = sum(p.length for p in runs) - st["link_mm"]
    assert paths_mm == pytest.approx(sum(p.length for p in greedy) - gs["link_mm"], rel=1e-9)
    # the program's own links: each end once, no loop among the paths
    kept = [p for p in tp.paths if len(p.points) >= 2]
    ps, _ = drop_fragments(kept, base.min_fragment * 0.45, base.fragment_share)
    layer = _Layer.of(ps, region, 0.45, base, tp.band)
    chosen = exact_links(layer, nodes)
    at = {tuple(np.round(q, 9).tolist()): e for e, q in enumerate(layer.e_pt)}
    ends = [(at[a], at[b]) for a, b, _ in chosen]
    flat = [e for pair in ends for e in pair]
    assert len(chosen) >= len(ps) - len(runs) - 2 and len(flat) == len(set(flat))
    parent = list(range(len(ps)))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    for a, b in ends:
        ra, rb = root(a // 2), root(b // 2)
        assert ra != rb, "a loop"
        parent[ra] = rb
