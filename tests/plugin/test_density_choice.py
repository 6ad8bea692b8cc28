"""``density = "auto"`` keeps the candidate the model predicts better (loadpath.plugin.density_choice).

The choice on real slices: tests/pipeline/test_sparse_strength.py."""

from __future__ import annotations

from pathlib import Path

from loadpath.plugin.density_choice import Choice, describe, score


def test_no_loss_ranks_first_then_the_product():
    # the L-bracket's figures (bench_sparse, PrusaSlicer gyroid 20 %): energy loses failure load
    assert score(1.179, 1.017) > score(1.155, 0.846)
    # the 3-point beam's: both keep, the larger product wins
    assert score(1.230, 1.879) > score(1.249, 1.310)
    assert score(None, None) < score(0.5, 0.5)
    assert score(1.1, None) == (1, 1, 1.1)


def test_a_candidate_off_the_slicers_mass_ranks_below_one_on_it():
    # bench_printability --principal alternate, CuraEngine 40 % beam: "stack" kept its minor layers
    # as sliced and laid +38 % plastic; its larger absolute ratios were bought with it
    assert score(1.140, 1.238, keeps_mass=True) > score(1.243, 1.333, keeps_mass=False)
    assert score(0.9, 0.9, keeps_mass=True) > score(2.0, 2.0, keeps_mass=False)


def test_the_verdict_names_the_kept_criterion_and_the_figures_that_chose_it():
    text = describe(Choice("stack", (("energy", 1.155, 0.846), ("stack", 1.179, 1.017))))
    assert text == ("'stack' (auto, by loadpath compare's model over the slicer's file: energy stiffness "
                    "1.155x, failure load 0.846x; stack stiffness 1.179x, failure load 1.017x)")
    assert describe(Choice("energy", (("energy", None, None),))) == (
        "'energy' (auto: nothing to judge by, the first candidate kept)")
    assert "failure load not predicted" in describe(Choice("energy", (("energy", 1.2, None),)))
    off = describe(Choice("energy", (("energy", 1.14, 1.238), ("stack", 1.243, 1.333)), (("stack", 0.38),)))
    assert off.endswith("; stack laid +38% of the slicer's plastic (blocks kept as sliced), not its mass)")


def test_the_first_judgment_side_by_side_gives_the_same_figures(tmp_path):
    """The Judge's first call evaluates the slicer's file and the candidate in two forked workers
    when it has two: the same ratios, bit for bit, as one after the other, and a later call (its
    body meshed again in this process) as well."""
    from loadpath import gcode, loadcase
    from loadpath.plugin.density_choice import judge
    from loadpath.plugin.job import JobRequest, run_job

    repo = Path(__file__).resolve().parents[2]
    src, case = repo / "examples" / "ohs.gcode", repo / "examples" / "ohs.toml"
    out = tmp_path / "out.gcode"
    res = run_job(JobRequest(src, case, output=out, cli={"cache": False}, predict=False))
    assert res.written, res.error
    pres = _Result(out.read_bytes(), {})
    program, lc = gcode.read(src), loadcase.read(case)
    one, two = judge(program, lc, 1), judge(program, lc, 2)
    first = [one(pres), two(pres)]
    again = [one(pres), two(pres)]
    assert first[0] == first[1] and again[0] == again[1] == first[0]
    assert first[0][0] > 1.0  # the example's new infill: stiffer in the model


class _Result:
    """What the Judge reads of a pipeline result (weakly referenced, as the pipeline's is)."""

    def __init__(self, data: bytes, analyses: dict) -> None:
        self.data, self.analyses = data, analyses
