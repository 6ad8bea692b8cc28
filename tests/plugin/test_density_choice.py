"""``density = "auto"`` keeps the candidate the model predicts better (loadpath.plugin.density_choice).

The choice on real slices: tests/pipeline/test_sparse_strength.py."""

from __future__ import annotations

from loadpath.plugin.density_choice import score


def test_no_loss_ranks_first_then_the_product():
    # the L-bracket's figures (bench_sparse, PrusaSlicer gyroid 20 %): energy loses failure load
    assert score(1.179, 1.017) > score(1.155, 0.846)
    # the 3-point beam's: both keep, the larger product wins
    assert score(1.230, 1.879) > score(1.249, 1.310)
    assert score(None, None) < score(0.5, 0.5)
    assert score(1.1, None) == (1, 1.1)
