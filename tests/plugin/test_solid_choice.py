"""Where the level sets give way on solid infill, the better layout is kept, a near tie by the printer
(loadpath.plugin.solid_choice; the tie itself: tests/plugin/test_density_choice.py).

Both layouts laid and judged on a real slice: tests/pipeline/test_sparse_engine.py."""

from __future__ import annotations

from loadpath.plugin.solid_choice import SolidChoice, describe


def test_the_verdict_says_a_tie_was_settled_by_retractions():
    tried = (("level sets", 1.008, 0.925), ("swarm", 1.007, 0.954))
    text = describe(SolidChoice(True, "swarm", tried, (149, 485)))
    assert text == (
        "level sets on every solid layer (by loadpath compare's model over the slicer's file: level sets "
        "stiffness 1.008x, failure load 0.925x; swarm stiffness 1.007x, failure load 0.954x; a tie within "
        "the model's 6% spread: retractions 149 against 485)"
    )
    assert describe(SolidChoice(False, "swarm", tried, (None, 485))).endswith(
        ": retractions not counted, the higher rank kept)")
    # decided by the ranks: no word of retractions
    assert "retractions" not in describe(SolidChoice(False, "swarm", tried))
