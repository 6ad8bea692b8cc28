"""A sparse run that links up short of the slicer's plastic is run again at a closer pitch (issue 15 / 19).

Sparse infill keeps the slicer's bead width, so a run's plastic is its length, and the splicer's
flow correction takes back 15 % at most.  The streamline engine on CuraEngine 4.13's 40 % L-bracket
(``benchmarks/bench_printability.py``'s part: 50 x 36 mm, 12 mm legs, 2.4 mm thick, 5 mm bolt hole)
laid 72-74 % of the slicer's line length at the slicer's 2 mm pitch; linked and corrected it stayed
at 91 %, and every block was kept as sliced: nothing replaced.  Judged on the engine's length alone
(before its links) the rule would also hit runs the links make up: it is applied to the linked runs
(:func:`loadpath.pipeline.paths.relay_factor`).  Since sparse infill is linked at the bead's share of
the clearance (:meth:`loadpath.engines.linking.LinkOptions.for_bead`) the links make this part's
runs up at once, so the test runs it unlinked (``link = false``): the engine's own paths are then
what is printed, and they fall short as before.
"""

from __future__ import annotations

import pytest
import slicing
from cases import BRACKET_TIP, TIP_BEND, side_case
from loadpath.pipeline.paths import RELAYS, length_target, relay_factor
from loadpath.plugin.job import JobRequest, run_job

BRACKET = BRACKET_TIP
"""The bench's L-bracket case: the wall at y_max held, 300 N down at the tip (x_max)."""


@pytest.mark.slow
def test_short_streamline_runs_are_run_again_and_every_block_is_replaced(tmp_path):
    stl = slicing.write_stl(slicing.bracket_mesh((50.0, 36.0), 12.0, 2.4, 5.0), tmp_path / "bracket.stl")
    src = slicing.slice_cura(
        stl, tmp_path / "bracket.gcode",
        **{**slicing.CURA_MIXED, "infill_sparse_density": "40", "infill_line_distance": "2.0"},
    )
    case = tmp_path / "bracket.toml"
    case.write_text(BRACKET, encoding="utf-8")
    cli = {"engine": "streamlines", "replace": ("sparse",), "density": "uniform"}
    cli["link"] = False  # the engine's own paths printed (module docstring)
    res = run_job(JobRequest(src, case, output=tmp_path / "out.gcode", cli=cli))
    assert res.written and res.error is None, res.error
    pr = res.pipeline
    assert pr.splice is not None and not pr.splice.skipped, pr.splice.skipped if pr.splice else None
    assert pr.check is not None and not pr.check.problems
    for b in pr.splice.blocks:  # each block at the slicer's plastic, within the splice's tolerance
        assert b.filament_new / b.filament_old == pytest.approx(1.0, abs=0.03)
    retried = [jr for jr in pr.jobs if "pitch_factor_after_links" in jr.paths.stats]
    assert retried, "the runs linked up to the slicer's length at once: this part no longer shows the case"
    for jr in retried:  # run again at a closer pitch, the linked layers now within the flow correction
        assert 0.6 <= jr.paths.stats["pitch_factor_after_links"] < 1.0
        linked = sum(p.length for p in (jr.printed or jr.paths.paths))  # unlinked: the engine's paths
        assert linked >= 0.85 * length_target(jr.job), (linked, length_target(jr.job))


@pytest.mark.slow
def test_runs_their_links_made_too_long_are_run_again_wider_and_every_block_is_replaced(tmp_path):
    """The other side (issue 15): the swarm's sparse runs on CuraEngine 4.13's 40 % cantilever
    (``bench_printability.py``'s beam, 80 x 12 x 2.4 mm, 200 N at the tip), linked at the bead's
    share of the clearance, came to 120 % of the slicer's length: past the flow correction, and four
    of eight blocks were kept as sliced.  Such a run is laid again at a wider pitch."""
    import trimesh

    beam = slicing._at_origin(trimesh.creation.box(extents=(80.0, 12.0, 2.4)))
    stl = slicing.write_stl(beam, tmp_path / "beam.stl")
    src = slicing.slice_cura(
        stl, tmp_path / "beam.gcode",
        **{**slicing.CURA_MIXED, "infill_sparse_density": "40", "infill_line_distance": "2.0"},
    )
    case = tmp_path / "beam.toml"
    case.write_text(TIP_BEND, encoding="utf-8")
    cli = {"engine": "swarm", "replace": ("sparse",), "density": "uniform"}
    res = run_job(JobRequest(src, case, output=tmp_path / "out.gcode", cli=cli))
    assert res.written and res.error is None, res.error
    pr = res.pipeline
    assert pr.splice is not None and not pr.splice.skipped, pr.splice.skipped
    assert pr.check is not None and not pr.check.problems
    for b in pr.splice.blocks:
        assert b.filament_new / b.filament_old == pytest.approx(1.0, abs=0.03)
    wider = [jr for jr in pr.jobs if jr.paths.stats.get("pitch_factor_after_links", 0) > 1.0]
    assert wider, "the linked runs came within the flow correction at once: the part no longer shows it"
    for jr in wider:
        linked = sum(p.length for p in jr.printed)
        assert linked <= 1.15 * length_target(jr.job), (linked, length_target(jr.job))


def test_the_relay_factor_brackets_a_layer_between_a_short_and_a_long_laying():
    t, r = 100.0, 0.15
    assert relay_factor([(1.0, 100.0)], t, r) is None  # within the flow correction: kept
    assert relay_factor([(1.0, 114.0)], t, r) is None
    short = relay_factor([(1.0, 70.0)], t, r)  # 70 % long: a closer pitch, aiming 7.5 % under
    assert short == pytest.approx(70.0 / 92.5)
    long = relay_factor([(1.0, 130.0)], t, r)  # 130 %: a wider one, aiming 7.5 % over
    assert long == pytest.approx(130.0 / 107.5)
    # laid short at 1.0 and long at 0.8: the next lies between, the geometric mean
    assert relay_factor([(1.0, 70.0), (0.8, 125.0)], t, r) == pytest.approx(0.8**0.5)
    # within _PITCH_STEP of the job's pitch, and never a factor tried already
    assert relay_factor([(1.0, 10.0)], t, r) == pytest.approx(0.6)
    assert relay_factor([(1.0, 10.0), (0.6, 12.0)], t, r) is None
    assert RELAYS >= 2


@pytest.mark.slow
def test_a_slender_part_whose_layer_and_copy_link_unlike_gets_its_sparse_infill_replaced(tmp_path):
    """A 150 x 8 x 3 mm cantilever at CuraEngine's 20 % grid (issue 15, found on parts kept aside):
    a layer links 123 % of the slicer's length and its staggered copy 77 %, and one pitch factor for
    both, from the shorter, left the other 136 %, so every sparse block was kept as sliced.  Each
    linked layer is now laid again on its own, up to RELAYS times, the closest laying kept."""
    import trimesh

    rib = slicing._at_origin(trimesh.creation.box(extents=(150.0, 8.0, 3.0)))
    stl = slicing.write_stl(rib, tmp_path / "rib.stl")
    src = slicing.slice_cura(stl, tmp_path / "rib.gcode", **{**slicing.CURA_MIXED, "top_layers": "3",
                                                              "bottom_layers": "3"})
    case = tmp_path / "rib.toml"
    case.write_text(side_case((0.0, -20.0, 0.0), held_within=10.0, loaded_within=10.0, load="tip"), encoding="utf-8")
    res = run_job(JobRequest(src, case, output=tmp_path / "out.gcode",
                             cli={"replace": ("solid", "sparse"), "density": "energy"}))
    assert res.written and res.error is None, res.error
    pr = res.pipeline
    assert pr.check is not None and not pr.check.problems
    assert any(jr.job.unit.kind == "sparse" for jr in pr.jobs)
    assert "replaced solid, sparse infill" in res.verdict.line(), res.verdict.line()
    kept = [why for _, why in pr.splice.skipped]
    assert not any("would extrude" in why for why in kept), kept  # 10 of its sparse blocks before
