"""Printable paths (issue 19): runs linked end to end, the slicer's retraction policy, the counts.

On real PrusaSlicer 2.5 / CuraEngine 4.13 slices; one pipeline run per slicer (the bracket at
100 %, the swarm engine), shared by the tests of this file.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import shapely
from cases import GRIP_PULL
from loadpath import gcode, loadcase, metrics
from loadpath.engines.linking import link_paths, pieces
from loadpath.splice.travel import Motion, TravelState, route
from loadpath.pipeline import PipelineOptions, run
from loadpath.plugin import settings as settings_mod
from loadpath.plugin.slicers import infer_from_moves
from loadpath.printability import Kinematics, measure, print_time, replaced_blocks
from shapely.geometry import Point, box


def _run(path):
    program = gcode.read(path)
    s = settings_mod.resolve(program)
    case = loadcase.parse(GRIP_PULL)
    opts = PipelineOptions(engine="swarm", engine_params={"K": s.K}, workers=1)
    return program, run(program, case, opts, settings_mod.splice_options(s))


@pytest.fixture(scope="module")
def prusa_run(sliced):
    return _run(sliced("prusa", "bracket", "solid"))


@pytest.fixture(scope="module")
def cura_run(sliced):
    return _run(sliced("cura", "bracket", "solid"))


def test_runs_are_fewer_never_cross_and_stay_inside(prusa_run):
    _, res = prusa_run
    assert res.check is not None and not res.check.problems
    for jr in res.jobs:
        u = jr.units[0]
        engine, printed = jr.paths.paths, jr.printed
        assert jr.links["links"] > 0 and len(printed) < 0.7 * len(engine), (len(engine), len(printed))
        lines = [shapely.LineString(p.points) for p in printed]
        assert metrics.crossings(printed) == 0
        grown = u.fill_region.buffer(1e-3)
        assert all(grown.covers(ln) for ln in lines)
        # the same plastic path: linking adds only the links' length
        kept = sum(p.length for p in printed) >= 0.99 * sum(p.length for p in engine) - 1e-6
        assert kept or jr.links["dropped"]


def test_links_keep_coverage_and_count_their_overlap(prusa_run):
    _, res = prusa_run
    jr = res.jobs[0]
    u = jr.units[0]
    runs, st = link_paths(jr.paths.paths, u.fill_region, u.pitch)
    before = metrics.coverage(jr.paths.paths, u.fill_region)
    after = metrics.coverage(pieces(runs, st["links_at"]), u.fill_region)
    assert after.coverage >= before.coverage - 0.005
    assert after.overlap >= before.overlap  # the links' beads on the ends they join are counted
    assert sum(len(p.points) for p in pieces(runs, st["links_at"])) >= sum(len(p.points) for p in runs)


def test_prusa_retractions_follow_the_slicer_and_the_report_shows_them(prusa_run):
    program, res = prusa_run
    p = replaced_blocks(program, res.output, res.splice)
    s, n = p["slicer"], p["loadpath"]
    assert n["paths"] >= 1 and n["retractions"] <= n["paths"] + len(res.splice.blocks)
    assert 0.97 <= n["filament_mm"] / s["filament_mm"] <= 1.03
    # PrusaSlicer MK3S (retract_before_travel = 1, not only when crossing): every travel in the new
    # blocks longer than 1 mm, or leaving the region, is retracted
    out = res.output
    st = out.state
    for rep in res.splice.blocks:
        for a, z in res.splice.output_ranges(program, rep.block):
            mv = out.moves[out.move_rows(a, z)]
            long = mv[mv["travel"] & (np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"]) > 1.0 + 1e-3)]
            assert all(st.retracted[int(r["line"])] > 0 or st.fw_retracted[int(r["line"])] for r in long)


def test_each_block_is_counted_with_its_way_out_to_the_next_extrusion(prusa_run):
    """The counts take each replaced block with the moves that lead out of it, up to the slicer's
    next extrusion (``loadpath.printability.block_windows``): where the new block ends decides the
    travel there, which the span alone did not count (issue 19: an order blind to it moved the
    cantilever's travel out of the count, 778 -> 699 mm counted, 1435 -> 1687 mm in the whole file).
    The ranges never overlap, no way out holds an extrusion, each ends on one (or on the next
    block), and the way out's travel in the output is at least the straight line from where the
    block leaves the nozzle to where the next extrusion starts."""
    from loadpath.printability import block_windows
    from loadpath.splice.splicer import next_extrusion

    program, res = prusa_run
    out = res.output
    old, new = block_windows(program, out, res.splice)
    for ranges in (old, new):
        assert all(z0 <= a1 for (_, z0), (a1, _) in zip(ranges, ranges[1:], strict=False))
    spans = {z for rep in res.splice.blocks for _, z in res.splice.output_ranges(program, rep.block)}
    ways = [(a, z) for a, z in new if a in spans]
    assert len(ways) >= len(res.splice.blocks) - 1  # the last block may end the file's extrusions
    extruding = np.flatnonzero(out.moves["extrude"])
    for a, z in ways:
        mv = out.moves[out.move_rows(a, z)]
        assert not mv["extrude"].any()
        here = out.state_before(a)  # after the block's leaving wipe
        nxt = next_extrusion(out, a, extruding)
        straight = float(np.hypot(nxt[0] - here.x, nxt[1] - here.y))
        travel = float(np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"])[mv["travel"]].sum())
        assert travel >= straight - 1e-6


def test_cura_combs_inside_the_infill_instead_of_retracting(cura_run):
    program, res = cura_run
    inferred = infer_from_moves(program)
    assert inferred["only_retract_when_crossing_perimeters"] is True
    assert inferred["avoid_crossing_perimeters"] is True
    assert res.check is not None and not res.check.problems
    p = replaced_blocks(program, res.output, res.splice)
    # Cura retracts almost never; the new blocks add at most one retraction per block
    assert p["loadpath"]["retractions"] <= p["slicer"]["retractions"] + len(res.splice.blocks) // 4 + 2
    assert p["loadpath"]["paths"] < p["slicer"]["paths"]


def test_cura_sparse_blocks_enter_over_the_walls_without_retracting(sliced):
    """CuraEngine 4.13, the L-bracket at 20 % grid, sparse infill replaced: CuraEngine retracts
    nowhere in these blocks (it combs).  Where a layer's block follows the outer wall, the nozzle
    stands 0.6-0.8 mm outside the infill region, and the first new run may lie round the corner:
    that travel is routed over the walls and inside the region, as Cura would comb it, instead of
    retracting (before: 2 retractions in the replaced blocks, 0 in the slicer's)."""
    grid20 = {"infill_pattern": "grid", "infill_line_distance": "8.0"}
    program = gcode.read(sliced("cura", "bracket", "mixed", **grid20))
    s = settings_mod.resolve(program)
    opts = PipelineOptions(replace=("solid", "sparse"), workers=1)
    res = run(program, loadcase.parse(GRIP_PULL), opts, settings_mod.splice_options(s))
    assert res.check is not None and not res.check.problems
    p = replaced_blocks(program, res.output, res.splice)
    assert sum(u.kind == "sparse" for jr in res.jobs for u in jr.units) >= 4
    assert p["loadpath"]["retractions"] <= p["slicer"]["retractions"]


def test_prusa_file_does_not_comb(sliced):
    program = gcode.read(sliced("prusa", "bracket", "solid"))
    assert infer_from_moves(program).get("only_retract_when_crossing_perimeters") in (False, None)


def test_counts_match_the_files_own_lines(sliced):
    path = sliced("prusa", "bracket", "solid")
    program = gcode.read(path)
    text = path.read_text(encoding="utf-8")
    m = measure(program.moves)
    # PrusaSlicer MK3S: every retraction ends with an E-only pull after its wipe
    assert m.retractions == len(re.findall(r"^G1 E-", text, re.M))
    # the firmware-style time is within 5 % of PrusaSlicer's own estimate (normal mode)
    est = re.search(r"estimated printing time \(normal mode\) = (?:(\d+)h )?(?:(\d+)m )?(\d+)s", text)
    secs = int(est.group(1) or 0) * 3600 + int(est.group(2) or 0) * 60 + int(est.group(3))
    assert abs(m.print_s / secs - 1) < 0.05, (m.print_s, secs)


def test_counts_made_beside_the_check_are_the_verdicts_own(sliced, prusa_run):
    """With two workers the check and the counts run side by side (pipeline._check_and_count): the
    same output bytes as one worker, a clean check, and the counts of the parsed output."""
    program, one = prusa_run
    assert one.counts is None  # one worker: the verdict counts later, from the parsed output
    s = settings_mod.resolve(program)
    opts = PipelineOptions(engine="swarm", engine_params={"K": s.K}, workers=2)
    two = run(program, loadcase.parse(GRIP_PULL), opts, settings_mod.splice_options(s))
    assert two.data == one.data
    assert two.check is not None and not two.check.problems
    counts, why = two.counts
    assert why == "" and counts == replaced_blocks(program, two.output, two.splice)


def _planner_by_loops(moves, kin):
    """print_time's planner written move by move (the reference its running minima must match)."""
    d = np.sqrt(sum((moves[k + "1"] - moves[k + "0"]) ** 2 for k in "xyz"))
    ok = (d > 1e-9) & np.isfinite(moves["f"]) & (moves["f"] > 0)
    d, v = d[ok], moves["f"][ok] / 60.0
    u = np.column_stack([moves[k + "1"][ok] - moves[k + "0"][ok] for k in "xyz"]) / d[:, None]
    n, a, j = len(d), kin.accel, kin.jerk
    entry = [min(j / 2.0, v[0])]
    for i in range(1, n):
        du = float(np.linalg.norm(u[i] - u[i - 1]))
        vj = min(v[i], v[i - 1], j / max(du, 1e-9))
        entry.append(max(vj, min(j / 2.0, v[i], v[i - 1])))
    entry.append(min(j / 2.0, v[-1]))
    for i in range(n):
        entry[i + 1] = min(entry[i + 1], (entry[i] ** 2 + 2 * a * d[i]) ** 0.5)
    for i in range(n - 1, -1, -1):
        entry[i] = min(entry[i], (entry[i + 1] ** 2 + 2 * a * d[i]) ** 0.5)
    t = 0.0
    for i in range(n):
        v0, v1 = entry[i], entry[i + 1]
        vp = min(v[i], ((2 * a * d[i] + v0**2 + v1**2) / 2.0) ** 0.5)
        s_acc, s_dec = (vp**2 - v0**2) / (2 * a), (vp**2 - v1**2) / (2 * a)
        t += (vp - v0) / a + (vp - v1) / a + max(d[i] - s_acc - s_dec, 0.0) / max(vp, 1e-9)
    return t


def test_print_time_matches_the_planner_move_by_move(sliced):
    program = gcode.read(sliced("prusa", "bracket", "solid"))
    kin = Kinematics(accel=1250.0, jerk=8.0)
    for layer in (1, len(program.layers) // 2):
        mv = program.moves[(program.moves["layer"] == layer) & ~program.moves["retract"]]
        mv = mv[np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"]) > 1e-9]
        assert print_time(mv, kin) == pytest.approx(_planner_by_loops(mv, kin), rel=1e-9)


def test_print_time_of_one_move_is_a_trapezoid():
    mv = np.zeros(1, dtype=gcode.MOVE_DTYPE)
    mv["x1"], mv["f"] = 100.0, 6000.0  # 100 mm at 100 mm/s
    kin = Kinematics(accel=1000.0, jerk=0.0)
    # from rest to rest: 0.1 s accelerating over 5 mm, 0.9 s cruising, 0.1 s braking
    assert print_time(mv, kin) == pytest.approx(1.1, rel=1e-6)


def test_route_goes_round_a_hole():
    region = box(0, 0, 40, 20).difference(Point(20, 10).buffer(4, quad_segs=16))
    st = TravelState(None, region, Motion(), 0.2)  # program is not used by route
    a, b = np.array([10.0, 10.0]), np.array([30.0, 10.0])
    way = route(st, a, b)
    assert way is not None and np.allclose(way[-1], b)
    full = np.vstack([a[None], way])
    assert region.buffer(2e-3).covers(shapely.LineString(full))
    assert 20.0 < np.sum(np.hypot(*np.diff(full, axis=0).T)) < 20.0 + 4 * np.pi
    assert route(st, np.array([10.0, 10.0]), np.array([10.0, 30.0])) is None  # outside the region


def test_route_takes_a_start_off_the_edge_straight_along_it():
    """CuraEngine's layer start: the travel before the block ends on its first infill line's end,
    0.04 mm outside the region found from the perimeters; the first new run starts a few mm along
    that edge.  The travel stays over the innermost perimeter, so it is taken straight (combing,
    not retracted); one that starts a millimetre out is not."""
    region = box(0, 0, 40, 20)
    st = TravelState(None, region, Motion(), 0.2)
    a, b = np.array([2.0, -0.04]), np.array([11.0, 0.1])
    way = route(st, a, b)
    assert way is not None and np.allclose(way, b[None])  # straight, not round the edge
    assert route(st, np.array([2.0, -1.0]), b) is None  # from a millimetre outside: no way inside
    # a piece off the edge in the middle of a travel still goes round (only the ends may hug it)
    hole = box(0, 0, 40, 20).difference(box(15, -1, 25, 0.2))
    mid = route(TravelState(None, hole, Motion(), 0.2), np.array([10.0, 0.1]), np.array([30.0, 0.1]))
    assert mid is not None and len(mid) > 1


def test_prusa_retracts_only_where_the_slicer_would(prusa_run):
    """Every retraction in the new blocks serves a gap (run end to next run start) of at least
    ``retract_before_travel``, or one leaving the region by more than the perimeter beside it:
    PrusaSlicer's ``GCode::needs_retraction`` skips shorter travels whatever they cross."""
    from loadpath.splice.travel import SHORT_REACH

    program, res = prusa_run
    out = res.output
    limit = float(str(program.config["retract_before_travel"]).split(",")[0])
    near = {}
    for jr in res.jobs:
        for u in jr.units:
            for b in u.blocks:
                near[b.block_index] = u.fill_region.buffer(SHORT_REACH)
    n_short = n_retracted = 0
    for rep in res.splice.blocks:
        for a, z in res.splice.output_ranges(program, rep.block):
            mv = out.moves[out.move_rows(a, z)]
            ext = np.flatnonzero(mv["extrude"])
            for i, j in zip(ext[:-1], ext[1:], strict=True):
                if j == i + 1:
                    continue
                gap = mv[i + 1 : j]
                p0 = (mv["x1"][i], mv["y1"][i])
                p1 = (mv["x0"][j], mv["y0"][j])
                d = float(np.hypot(p1[0] - p0[0], p1[1] - p0[1]))
                pulled = bool(np.any(gap["retract"] | gap["wipe"]))
                n_retracted += pulled
                if d < limit - 1e-3 and near[rep.block].covers(shapely.LineString([p0, p1])):
                    n_short += 1
                    assert not pulled, (d, p0, p1)
    assert n_retracted > 0 and n_short > 0


def test_parallel_paths_link_into_one_zigzag():
    """44 straight paths across a 20 x 10 mm plate, a pitch apart (a uniaxial field's paths): one run,
    as the slicer's rectilinear zig-zag.  Taking the candidate links shortest first over the whole
    layer (``grow_chains = False``) links both ends of neighbours, closes loops and leaves 8 runs."""
    from loadpath.engines.linking import LinkOptions
    from loadpath.toolpath import Path

    w = 0.45
    xs = 0.225 + w * np.arange(44)
    paths = [Path(np.array([[x, 0.2], [x, 5.0], [x, 9.8]]), np.full(3, w), "fill") for x in xs]
    region = box(0, 0, 20, 10)
    runs, st = link_paths(paths, region, w)
    assert len(runs) == 1 and st["links"] == 43
    assert metrics.crossings(runs) == 0 and region.buffer(1e-3).covers(shapely.LineString(runs[0].points))
    assert len(link_paths(paths, region, w, LinkOptions(grow_chains=False))[0]) > 4


@pytest.fixture(scope="module")
def prusa_shelf_run(sliced):
    return _run(sliced("prusa", "shelf", "solid"))


def test_cuts_pair_ends_that_cost_a_retraction(prusa_run, prusa_shelf_run):
    """Issue 19: free run ends with paths between them and no other end within PrusaSlicer's
    ``retract_before_travel`` (1 mm) each cost a retracted travel; cuts in the paths between them,
    where the stress is low, pair them (``loadpath.engines.cuts``).  On the real bracket's and shelf
    bracket's layers: never more runs or groups of runs apart, nothing crossed, coverage kept; and
    fewer groups over both (the slices of ``tests/slicing.PRUSA_ENV``, 2026-12-06: bracket 69 -> 69
    with no cut, shelf 303 -> 257 with 192; an earlier slice of the bracket, whose coordinates round
    its bolt hole differed by up to 0.08 mm, 75 -> 68 with 35).  The code before the cuts left every
    group as it was.  (Cuts are off by default: their stiffness cost, ``LinkOptions.cut_reach``.)"""
    from loadpath.engines.linking import LinkOptions, hop_groups

    before = after = cuts = 0
    for _, res in (prusa_run, prusa_shelf_run):
        for jr in res.jobs:
            u = jr.units[0]
            field = jr.job.input.field
            ps, region = jr.paths.paths, u.fill_region
            old, _ = link_paths(ps, region, u.pitch, LinkOptions(cut_reach=0), field=field)
            new, st = link_paths(ps, region, u.pitch, LinkOptions(cut_reach=7.0), field=field)
            assert len(new) <= len(old) and hop_groups(new, 1.0) <= hop_groups(old, 1.0)
            assert metrics.crossings(new) == 0
            grown = u.fill_region.buffer(1e-3)
            assert all(grown.covers(shapely.LineString(p.points)) for p in new)
            c0 = metrics.coverage(old, u.fill_region).coverage
            assert metrics.coverage(new, u.fill_region).coverage >= c0 - 0.002
            before += hop_groups(old, 1.0)
            after += hop_groups(new, 1.0)
            cuts += st["cuts"]
    assert cuts > 0 and after < before, (before, after, cuts)


def test_batched_candidate_tests_link_real_layers_as_one_by_one(prusa_run):
    """On the real bracket's layers (every job's engine paths in its region) the batched candidate
    tests of ``loadpath.engines.linking`` link exactly as the tests made one link at a time did
    (``tests/linking_reference.py``); the first job's every candidate is compared too."""
    from linking_reference import assert_links_as_one_by_one

    _, res = prusa_run
    laid = 0
    for k, jr in enumerate(res.jobs):
        u = jr.units[0]
        laid += assert_links_as_one_by_one(list(jr.paths.paths), u.fill_region, u.pitch, every=k == 0)[0]
    assert laid > 0


def test_sparse_links_chosen_all_at_once_cost_fewer_retractions(sliced, monkeypatch):
    """PrusaSlicer 2.5, the open-hole specimen at 40 % rectilinear, sparse infill replaced: the
    sparse layers' links are chosen all at once too (``loadpath.pipeline.SPARSE_EXACT``), and the
    replaced blocks retract less than with the greedy linking alone (66 -> 51 when written), with
    the same blocks replaced and the splice checks clean."""
    import loadpath.pipeline as pipeline

    program = gcode.read(sliced("prusa", "ohs", "mixed", fill_density="40%"))
    s = settings_mod.resolve(program)
    opts = PipelineOptions(replace=("sparse",), workers=1)
    got = {}
    for exact in (0, pipeline.SPARSE_EXACT):
        monkeypatch.setattr(pipeline, "SPARSE_EXACT", exact)
        res = run(program, loadcase.parse(GRIP_PULL), opts, settings_mod.splice_options(s))
        assert res.check is not None and not res.check.problems
        p = replaced_blocks(program, res.output, res.splice)
        got[exact] = p["loadpath"]["retractions"], sorted(b.block for b in res.splice.blocks)
    assert pipeline.SPARSE_EXACT > 0
    (greedy, blocks), (at_once, blocks_now) = got[0], got[pipeline.SPARSE_EXACT]
    assert blocks_now == blocks and len(blocks) >= 4
    assert at_once < greedy


def test_sparse_links_are_chosen_one_by_one_where_the_file_combs(sliced, monkeypatch):
    """CuraEngine 4.13 combs inside the infill (no retraction to save): its sparse layers keep the
    greedy linking, whose runs are fewer links and more plastic in the lines (``SPARSE_EXACT``)."""
    import loadpath.pipeline as pipeline

    program = gcode.read(sliced("cura", "ohs", "mixed"))
    s = settings_mod.resolve(program)
    opts = PipelineOptions(replace=("sparse",), workers=1)
    out = []
    for exact in (0, pipeline.SPARSE_EXACT):
        monkeypatch.setattr(pipeline, "SPARSE_EXACT", exact)
        res = run(program, loadcase.parse(GRIP_PULL), opts, settings_mod.splice_options(s))
        assert res.check is not None and not res.check.problems and res.splice.blocks
        out.append(res.data)
    assert out[0] == out[1]


def test_level_sets_cut_at_the_neutral_axis_are_linked_along_their_band(sliced, monkeypatch):
    """The bracket at 100 % under its pin load, the level-set engine (the product lays them first on
    solid infill and keeps them where the model ranks them as well as the swarm,
    ``loadpath.plugin.solid_choice``): they end on their jump cut, the engine hands that band to the linking
    (``Toolpaths.band``) and the linking joins the ends along it and inserts runs into earlier links;
    the runs cross nothing and the splice checks stay clean."""
    import loadpath.pipeline as pipeline_mod
    from cases import BRACKET_PIN

    bands, real = [], pipeline_mod.link_paths

    def spy(paths, region, pitch, options, field=None, band=None):
        bands.append(band)
        return real(paths, region, pitch, options, field=field, band=band)

    monkeypatch.setattr(pipeline_mod, "link_paths", spy)
    program = gcode.read(sliced("prusa", "bracket", "solid"))
    s = settings_mod.resolve(program)
    opts = PipelineOptions(engine="levelset", workers=1)
    res = run(program, loadcase.parse(BRACKET_PIN), opts, settings_mod.splice_options(s))
    assert res.check is not None and not res.check.problems
    assert any(b is not None and not b.is_empty for b in bands), len(bands)
    laid = [jr for jr in res.jobs if jr.engine == "levelset"]
    assert laid and sum(jr.links.get("inserted", 0) for jr in laid) > 0
    for jr in res.jobs:
        assert metrics.crossings(jr.printed) == 0
