"""What a solid choice's own figures keep (``loadpath.plugin.solid_choice``'s rule, read back from what
the verdict reports), for the tests that run real jobs and check the layout kept."""

from __future__ import annotations

from loadpath.plugin.density_choice import score, tie


def kept_layout(choice) -> int:  # type: ignore[no-untyped-def]
    """Which of a solid choice's layouts its own figures keep: the best rank, or among those tied
    with it the fewest retractions (the higher rank where any is not counted)."""
    ratios = [t[1:] for t in choice.tried]
    top = max(range(len(ratios)), key=lambda k: (score(*ratios[k]), -k))
    tied = [k for k in range(len(ratios)) if k != top and tie(ratios[top], ratios[k], choice.spread)]
    n = choice.retractions
    if not tied:
        assert n == (), choice
        return top
    assert len(n) == len(ratios), choice
    return top if None in n else min([top, *tied], key=lambda k: (n[k], k != top))
