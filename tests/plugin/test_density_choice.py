"""``density = "auto"`` keeps the candidate the model predicts better (loadpath.plugin.density_choice).

The choice on real slices: tests/pipeline/test_sparse_strength.py."""

from __future__ import annotations

from loadpath.plugin.density_choice import Choice, describe, score


def test_no_loss_ranks_first_then_the_product():
    # the L-bracket's figures (bench_sparse, PrusaSlicer gyroid 20 %): energy loses failure load
    assert score(1.179, 1.017) > score(1.155, 0.846)
    # the 3-point beam's: both keep, the larger product wins
    assert score(1.230, 1.879) > score(1.249, 1.310)
    assert score(None, None) < score(0.5, 0.5)
    assert score(1.1, None) == (1, 1.1)


def test_the_verdict_names_the_kept_criterion_and_the_figures_that_chose_it():
    text = describe(Choice("stack", (("energy", 1.155, 0.846), ("stack", 1.179, 1.017))))
    assert text == ("'stack' (auto, by loadpath compare's model over the slicer's file: energy stiffness "
                    "1.155x, failure load 0.846x; stack stiffness 1.179x, failure load 1.017x)")
    assert describe(Choice("energy", (("energy", None, None),))) == (
        "'energy' (auto: nothing to judge by, the first candidate kept)")
    assert "failure load not predicted" in describe(Choice("energy", (("energy", 1.2, None),)))
