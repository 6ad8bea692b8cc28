"""Where the level sets give way on solid infill, the better layout is kept, a near tie by the printer
(loadpath.plugin.solid_choice).

Both layouts laid and judged on a real slice: tests/pipeline/test_sparse_engine.py."""

from __future__ import annotations

from loadpath.plugin.solid_choice import SPREAD, SolidChoice, describe, keep_whole


def test_the_level_sets_are_kept_where_they_rank_at_least_as_high():
    # the cantilever's figures (bench_printability, PrusaSlicer 100 %): the level sets win outright
    assert keep_whole((1.025, 0.942), (1.031, 0.925)) == (True, False)
    assert keep_whole((1.0, 1.0), (1.0, 1.0)) == (True, False)


def test_the_swarm_is_kept_where_it_beats_the_model_spread():
    # issue 15's 12 mm beam, CuraEngine 20 %: the swarm's failure load 3.004x against 2.193x
    assert keep_whole((1.50, 2.193), (1.51, 3.004)) == (False, False)
    # no loss against a loss beyond the spread
    assert keep_whole((1.0, 0.90), (1.0, 1.0)) == (False, False)


def test_a_rank_closer_than_the_spread_is_a_tie():
    # the L-bracket's single run (PrusaSlicer 100 %): level sets 1.008 / 0.925, swarm 1.007 / 0.954
    assert keep_whole((1.008, 0.925), (1.007, 0.954)) == (False, True)
    # just inside and just outside the spread, on failure load alone
    assert keep_whole((1.0, 1.2), (1.0, 1.2 * (1 + SPREAD) * 0.999)) == (False, True)
    assert keep_whole((1.0, 1.2), (1.0, 1.2 * (1 + SPREAD) * 1.001)) == (False, False)
    # a missing failure load counts as unchanged (density_choice.score)
    assert keep_whole((1.0, None), (1.0, 1.03)) == (False, True)


def test_the_verdict_says_a_tie_was_settled_by_retractions():
    tried = (("level sets", 1.008, 0.925), ("swarm", 1.007, 0.954))
    text = describe(SolidChoice(True, "swarm", tried, (153, 499)))
    assert text == (
        "level sets on every solid layer (by loadpath compare's model over the slicer's file: level sets "
        "stiffness 1.008x, failure load 0.925x; swarm stiffness 1.007x, failure load 0.954x; a tie within "
        "the model's 6% spread: 153 retractions against 499)"
    )
    # the swarm kept in a tie: its own count first
    assert describe(SolidChoice(False, "swarm", tried, (153, 120))).endswith(": 120 retractions against 153)")
    assert describe(SolidChoice(True, "swarm", tried, (None, 499))).endswith(": retractions not counted)")
    # decided by the ranks: no word of retractions
    assert "retractions" not in describe(SolidChoice(False, "swarm", tried))
