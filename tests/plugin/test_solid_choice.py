"""Where the level sets give way on solid infill, the better layout is kept, a near tie by the printer
(loadpath.plugin.solid_choice; the tie itself: tests/plugin/test_density_choice.py).

Both layouts laid and judged on a real slice: tests/pipeline/test_sparse_engine.py."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

from loadpath.plugin.density_choice import SPREAD, run_choosing
from loadpath.plugin.solid_choice import THROUGH, WHOLE, SolidChoice, SolidChooser, describe


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


# SolidChooser inside density = "auto" (run_choosing with ``rank_by``), on fakes of the pipeline's
# results: what the two read of them is the layout's figures and its retractions

@dataclass(frozen=True)
class _Density:
    criterion: str = "energy"
    fill: None = None


@dataclass(frozen=True)
class _Options:
    density: _Density = _Density()
    solid_first: str = "levelset"
    solid_first_params: dict = field(default_factory=dict)


class _Laid:
    """A run's result: its sparse job, whether its solid layers gave way (the first layout laid),
    and its retractions as the check counted them."""

    def __init__(self, crit: str, layout: str, retractions: int) -> None:
        self.crit, self.layout, self.changed, self.splice = crit, layout, True, None
        stats = {"gave_way": layout == "swarm"}
        self.jobs = [SimpleNamespace(job=SimpleNamespace(unit=SimpleNamespace(kind="sparse")),
                                     paths=SimpleNamespace(stats=stats), engine="swarm")]
        self.counts = ({"loadpath": {"retractions": retractions}}, "")


def _layout(o: _Options) -> str:
    p = o.solid_first_params
    return "swarm" if p.get("give_way", True) else (THROUGH if p.get("heal") else WHOLE)


def _by_layout(energy: tuple, stack: tuple) -> dict:
    """Per candidate, one value per layout in the order the verdict names them (ending on the cut,
    through it, the swarm), keyed ``(criterion, layout)``."""
    return {(crit, lay): v for crit, vs in (("energy", energy), ("stack", stack))
            for lay, v in zip((WHOLE, THROUGH, "swarm"), vs, strict=True)}


def _choose_both(figures: dict, retractions: dict):
    """``density = "auto"`` over both candidates, each laying the three layouts (job.py's wiring)."""
    laid = {k: _Laid(*k, n) for k, n in retractions.items()}
    chooser = SolidChooser(lambda o: laid[o.density.criterion, _layout(o)],
                           lambda r: figures[r.crit, r.layout])
    pres, density = run_choosing(chooser, chooser.predict, _Options(), SPREAD, chooser.ranked)
    return pres, density, chooser.choice(pres)


def test_each_density_candidate_prints_the_layout_its_own_tie_settled():
    """The unseen-parts sweep's T at PrusaSlicer 40 %, sparse replaced (the ``stack`` candidate's
    figures and retractions as measured, ``energy``'s alike): the three layouts within 0.4 % of
    stiffness and 1.5 % of failure load.  Settled once, between the candidates, both printed the
    swarm's 760 retractions; each settled inside, the level sets through the cut's 82 (and the
    candidates, tied, by the rank of their first layouts)."""
    figures = _by_layout(((1.366, 1.780), (1.366, 1.775), (1.371, 1.787)),
                         ((1.368, 1.796), (1.369, 1.791), (1.374, 1.819)))
    retractions = _by_layout((228, 82, 760), (228, 82, 760))
    pres, density, solid = _choose_both(figures, retractions)
    assert (pres.crit, pres.layout) == ("stack", THROUGH)
    assert solid.through and solid.retractions == (228, 82, 760)
    # the candidates are named by the figures that ranked them: each one's swarm, ranked first in it
    assert density.tried == (("energy", 1.371, 1.787), ("stack", 1.374, 1.819))
    assert density.retractions == (82, 82)


def test_a_candidate_is_ranked_by_its_first_layout_not_by_the_one_its_tie_settled():
    """Issue 15's 12 mm beam at PrusaSlicer 20 %: ranked by the level sets its tie settled
    (1.361 / 1.748), ``stack`` fell behind ``energy`` by 1.8 % of stiffness, beyond the spread, and
    ``energy`` was printed with 503 retractions; ranked by its swarm (1.366 / 1.797) it ties ``energy``
    and prints its level sets with fewer."""
    figures = _by_layout(((1.300, 1.500), (1.300, 1.500), (1.386, 1.751)),
                         ((1.361, 1.748), (1.250, 1.400), (1.366, 1.797)))
    retractions = _by_layout((90, 80, 503), (420, 70, 476))
    pres, density, solid = _choose_both(figures, retractions)
    assert (pres.crit, pres.layout) == ("stack", WHOLE)
    assert not solid.through and solid.whole and solid.retractions == (420, 70, 476)
    assert density.criterion == "stack" and density.retractions == (503, 420)


def test_ties_do_not_chain_from_candidate_to_candidate():
    """The sweep's plate with three holes at PrusaSlicer 40 % (figures as measured): ``stack``'s
    layouts tie and it prints the one through the cut (1.355 / 1.844, 99 retractions), 8.6 % of
    failure load below ``energy``'s 2.017, though ``stack``'s first (1.354 / 1.926) ties ``energy``.
    What a candidate prints must lie within the spread of the best: ``energy`` is kept."""
    figures = _by_layout(((1.345, 2.017), (1.346, 1.861), (1.345, 1.976)),
                         ((1.354, 1.926), (1.355, 1.844), (1.355, 1.920)))
    retractions = _by_layout((176, 120, 700), (181, 99, 726))
    pres, density, solid = _choose_both(figures, retractions)
    assert (pres.crit, pres.layout) == ("energy", WHOLE)
    assert density.retractions == () and solid.retractions == (176, 120, 700)
    # had stack printed its first layout, with fewer retractions, the candidates would tie and it
    # would be kept
    retractions[("stack", WHOLE)], retractions[("stack", THROUGH)] = 150, 999
    pres, density, _ = _choose_both(figures, retractions)
    assert (pres.crit, pres.layout) == ("stack", WHOLE) and density.retractions == (176, 150)


def _geometry(*kinds: str):
    """A fake PrintGeometry of one layer holding blocks of these kinds (``LayerGeometry.kinds``)."""
    layer = SimpleNamespace(kinds=tuple(sorted(set(kinds))))
    return SimpleNamespace(objects=[SimpleNamespace(layers=[layer])])


def test_a_part_not_judged_keeps_the_level_sets_only_when_printed_solid():
    """A 3D part (the model does not judge it on every run): printed solid, the level sets on every
    solid layer, said so in the verdict; with sparse infill in the file, the swarm where they gave
    way, as before."""
    for kinds, layout in ((("solid", "top"), WHOLE), (("solid", "sparse"), "swarm")):
        laid = {lay: _Laid("energy", lay, 0) for lay in (WHOLE, THROUGH, "swarm")}
        for r in laid.values():
            r.geometry = _geometry(*kinds)
        runs = []
        chooser = SolidChooser(lambda o: runs.append(_layout(o)) or laid[_layout(o)], lambda r: None)
        pres = chooser(_Options())
        assert pres.layout == layout and runs == ["swarm", WHOLE][: 2 if layout == WHOLE else 1]
        choice = chooser.choice(pres)
        if layout == "swarm":
            assert choice is None
        else:
            assert not choice.judged and choice.tried == () and describe(choice) == (
                "level sets on every solid layer (not judged: a 3D part printed solid, where every solid "
                "part judged ranked the level sets within the model's spread of the swarm)"
            )
