"""Solid infill where the level sets give way: both layouts laid, the one the mechanics model prefers kept.

With no engine named, solid infill is laid by the level sets, which give way to the swarm on the
layers where their fit is cut along the layer (a bending part's neutral axis:
:data:`loadpath.engines.levelset.GIVE_WAY`).  Whether the level sets' ends on that cut cost the part
depends on the part, so the cut alone cannot decide it:

* issue 15's 12 mm bent parts with sparse infill (``benchmarks/bench_sparse.py``): the first ply
  fails among those ends in the internal solid layers under the top skins (3-point beam, CuraEngine
  20 %: failure load 3.004x the slicer's with the swarm on solid infill, 2.193x with the level sets;
  ``benchmarks/printability_results.md``, eleventh round);
* the 2.4 mm bent parts printed solid (``benchmarks/bench_printability.py``, 100 %; median of three
  runs with the force turned by 0, 0.0003 and -0.001 rad, which moves a first-ply failure load by up
  to 6 %): level sets against the swarm, stiffness / failure load over the slicer's, cantilever
  PrusaSlicer 1.025 / 0.942 against 1.031 / 0.925 with 105 retractions against 570, CuraEngine
  0.999 / 0.997 against 0.998 / 0.953; L-bracket PrusaSlicer 1.008 / 0.925 against 1.007 / 0.921
  with 153 against 499, CuraEngine 0.991 / 0.941 against 0.984 / 0.899.

So where a job gave way, the run lays the part again with the level sets on every solid layer,
twice: ending on the cut (:data:`WHOLE`), and through it (:data:`THROUGH`: the followed direction
healed across the cut, :data:`loadpath.engines.levelset.HEAL`, so that on a beam the lines run along
it through the neutral axis instead of ending there in families of nested U's, each its own run and
retraction). It keeps the layout the model of ``loadpath compare`` predicts better, ranked as
``density = "auto"`` ranks its candidates (:func:`loadpath.plugin.density_choice.score`: no loss
first, then stiffness times failure load). With ``density = "auto"`` the choice is made for each
density candidate: made once for the first and held for the second, it cost issue 15's 12 mm beam at
PrusaSlicer 40 % its failure load (3.329 -> 3.050x the slicer's) where the two layouts ranked the
other way under the second criterion; made for each, every layout the run chose from before is still
among those ranked.

A part the model does not judge on every run (3D analyses) keeps the swarm where the level sets gave
way, unless it has no sparse infill (printed solid): then it keeps the level sets on every solid
layer, unjudged.  Every solid part judged ranked them within the model's spread of the swarm or
above it (the cantilever and L-bracket below; the six parts kept aside of the twenty-second round of
``benchmarks/printability_results.md`` at PrusaSlicer and CuraEngine 100 %, the closest the rib at
PrusaSlicer: 1.042 / 0.958 against the swarm's 1.045 / 1.011), and on ``benchmarks/bench_printability.py``'s
tapered cantilever at PrusaSlicer 100 % (a 3D analysis; ``loadpath compare``, 1.6 min each) the
level sets predicted 1.002x / 0.972x the slicer's stiffness / failure load against the swarm's
1.007x / 0.971x, with 83 retractions in the replaced blocks against 464 (the slicer's 26).  With
sparse infill the swarm stays: there the first ply can fail among the level sets' ends in the solid
layers under the skins (issue 15's beam above).

Through the cut, on ``benchmarks/bench_printability.py``'s PrusaSlicer cantilever at 100 % (2026-12-06):
stiffness / failure load over the slicer's 1.028 / 0.929 against the cut level sets' 1.024 / 0.937
and the swarm's 1.030 / 0.919, a tie, and 20 retractions in the replaced blocks against 80 and 504
(the slicer's 10): kept; coverage 0.961 -> 0.981, print time of the blocks 0.95 -> 0.74x the
slicer's.  Where the bolt hole's or the load's stress turns too, the blend crosses it and the
model says so (the L-bracket through the cut: 0.941 / 0.546), and the other layouts stay.

A near tie is settled at the printer, as ``density = "auto"`` settles its own
(:func:`loadpath.plugin.density_choice.tie`): the model's failure load of one part moves by up to 6 %
between layouts laid from fields that differ by round-off, while the swarm's fragments cost three to
five times the level sets' retractions on the same files (on CuraEngine's files, which retract
nowhere in the infill, the replaced blocks' print time settles it:
:data:`loadpath.plugin.density_choice.QUICKER`).  On the PrusaSlicer L-bracket above, one run judged
the level sets 1.008 / 0.925 and the swarm 1.007 / 0.954 and kept the swarm, with 485 retractions
against the level sets' 149 (the slicer's: 25); the median of the three runs had ranked them the
other way.

With ``density = "auto"`` each density candidate settles its own tie, and so prints the layout it
settled; the candidates are ranked by the layout the model ranked first in each
(:meth:`SolidChooser.ranked`), and their own tie is settled between the layouts they print
(:func:`loadpath.plugin.density_choice.run_choosing`).  Before 2026-12-06 the layout inside a
candidate went by rank alone and the tie was settled once, between the candidates: on a T (80 x 15 mm
bar, 15 x 52 mm stem, 4 mm thick) fixed along its bar and pushed sideways at its stem's foot,
PrusaSlicer 40 % with ``--replace solid,sparse``, both candidates printed the swarm on their solid
layers, 760 retractions in the replaced blocks (the slicer's: 37) against the level sets' 82 through
the cut, which the model put within 0.4 % of its stiffness and 1.5 % of its failure load; print time
+5.5 % against +1.1 %, travel 4124 against 1981 mm (the slicer's 2027).  Ranking a candidate by the
layout its tie settled instead would have cost issue 15's 12 mm beam at PrusaSlicer 20 %: the
``stack`` candidate's level sets (1.361 / 1.748) instead of its swarm (1.366 / 1.797) made
``energy`` rank first, with 503 retractions against 476.  Ties do not chain: a candidate below the
best ties it only where the layout it prints does (on a plate with three holes at PrusaSlicer 40 %,
``stack``'s first layout tied ``energy``'s, 1.926 against 2.017 of failure load, but it would print
the layout through the cut, 1.844, 8.6 % below: ``energy`` is kept).  A file with no sparse
infill (printed at 100 %) gets no density choice: its tie is settled here alone (a 150 x 8 mm
slender cantilever at PrusaSlicer 100 % with ``--replace solid,sparse``: the level sets' 112
retractions, not the swarm's 713).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from loadpath.plugin.density_choice import SPREAD, figure, score, settle, settled, tie

__all__ = [
    "SolidChoice", "SolidChooser", "gave_way", "solid_only", "describe", "WHOLE", "THROUGH", "UNJUDGED",
]


WHOLE = "level sets"
"""The layout of the level sets on every solid layer, each side of the cut ending on it."""

THROUGH = "level sets through the cut"
"""The layout of the level sets on every solid layer, their direction healed across the cut
(:data:`loadpath.engines.levelset.HEAL`), so that they run through it."""


@dataclass(frozen=True)
class SolidChoice:
    """What the run laid on the solid layers where the level sets gave way, and why.

    Attributes
    ----------
    whole : bool
        True: the level sets on every solid layer were kept (``through`` says which); False: the
        swarm where they gave way.
    given_way : str
        The engine the level sets gave way to.
    tried : tuple of (str, float, float or None)
        Per layout (:data:`WHOLE`, :data:`THROUGH` where it was laid and judged, then the engine
        given way to): predicted stiffness and failure-load ratios over the slicer's file.
    retractions : tuple of (int or None)
        Per layout, in the same order: retractions in its replaced blocks, where they settled a tie
        (:func:`loadpath.plugin.density_choice.settle`); ``()`` where the model's ranks decided.
    spread : float
        The share within which ranks were a tie (setting ``tie_spread``).
    through : bool
        The level sets kept are those through the cut (:data:`THROUGH`).
    seconds : tuple of (float or None)
        Per layout, as ``retractions``: the print time of its replaced blocks, s.
    judged : bool
        False: the model did not judge the part (a 3D analysis) and it has no sparse infill, so the
        level sets were kept unjudged (:data:`UNJUDGED`); ``tried`` is empty.
    """

    whole: bool
    given_way: str
    tried: tuple[tuple[str, float, float | None], ...]
    retractions: tuple[int | None, ...] = ()
    spread: float = SPREAD
    through: bool = False
    judged: bool = True
    seconds: tuple[float | None, ...] = ()


UNJUDGED = (
    "not judged: a 3D part printed solid, where every solid part judged ranked the level sets within "
    "the model's spread of the swarm"
)
"""Why a part the model does not judge, printed solid, keeps the level sets (:class:`SolidChooser`)."""


def solid_only(pres: Any) -> bool:
    """Whether a pipeline result's file has no sparse infill (a part printed solid: every infill
    block ``solid`` or a skin)."""
    geo = getattr(pres, "geometry", None)
    if geo is None:
        return False
    return not any("sparse" in lg.kinds for o in geo.objects for lg in o.layers)


def gave_way(pres: Any) -> str | None:
    """The engine some of a pipeline result's solid jobs gave way to, or None (none gave way)."""
    for run in getattr(pres, "jobs", ()):
        if run.paths.stats.get("gave_way"):
            return str(run.engine)
    return None


class SolidChooser:
    """``run`` for :func:`loadpath.plugin.density_choice.run_choosing` (or called once): a pipeline
    run that, where the level sets gave way, also lays them on every solid layer and keeps the
    better of the two (module docstring).

    Parameters
    ----------
    run : callable
        ``run(pipeline_options) -> PipelineResult``.
    predict : callable
        ``predict(pipeline_result) -> (stiffness ratio, failure-load ratio) or None``
        (:class:`loadpath.plugin.density_choice.Judge`: a result judged twice is evaluated once).
    spread : float
        Ties within this share of failure load go to fewer retractions (setting ``tie_spread``).
    """

    def __init__(
        self, run: Callable[[Any], Any], predict: Callable[[Any], Any], spread: float = SPREAD,
    ) -> None:
        self.run = run
        self.predict = predict
        self.spread = spread
        # id(kept result) -> (that result, the choice that kept it, the ratios of the layout the
        # model ranked first): held, so no other takes its id
        self._chosen: dict[int, tuple[Any, SolidChoice, Any]] = {}

    def choice(self, pres: Any) -> SolidChoice | None:
        """The choice that kept ``pres`` (a result this returned), or None (nothing gave way)."""
        got = self._chosen.get(id(pres))
        return got[1] if got is not None and got[0] is pres else None

    def ranked(self, pres: Any) -> Any:
        """The predicted ratios of the layout the model ranked first where ``pres`` (a result this
        returned) was kept from a tie with it at the printer; None where ``pres`` is that layout or
        nothing was chosen.  ``density = "auto"`` ranks its candidates by these
        (:func:`loadpath.plugin.density_choice.run_choosing`, ``rank_by``)."""
        got = self._chosen.get(id(pres))
        return got[2] if got is not None and got[0] is pres else None

    def __call__(self, options: Any) -> Any:
        pres = self.run(options)
        other = gave_way(pres) if options.solid_first is not None and pres.changed else None
        if other is None:
            return pres
        split = self.predict(pres)
        params = {**options.solid_first_params, "give_way": False}
        if split is None:  # not judged (3D): a part printed solid takes the level sets (module docstring)
            if not solid_only(pres):
                return pres  # the layers given way keep the other engine
            kept = self.run(replace(options, solid_first_params=params))
            if not kept.changed:
                return pres
            choice = SolidChoice(True, other, (), (), self.spread, False, judged=False)
            self._chosen[id(kept)] = (kept, choice, None)
            return kept
        from loadpath.engines.levelset import HEAL  # not at start-up: the engine's imports are heavy

        laid = [(WHOLE, self.run(replace(options, solid_first_params=params)))]
        laid.append((THROUGH, self.run(replace(options, solid_first_params={**params, "heal": HEAL}))))
        # (name, result, ratios), in the order that keeps the earlier on equal ranks
        judged = [(name, r, self.predict(r)) for name, r in laid if r.changed]
        judged = [j for j in judged if j[2] is not None] + [(other, pres, split)]
        if len(judged) == 1:
            return pres
        first = top = max(range(len(judged)), key=lambda k: (score(*judged[k][2]), -k))
        retr: tuple[int | None, ...] = ()
        secs: tuple[float | None, ...] = ()
        tied = [
            k for k in range(len(judged)) if k != first and tie(judged[first][2], judged[k][2], self.spread)
        ]
        if tied:  # within the model's spread: the printer decides, among those tied with the best
            top, retr, secs = settle([j[1] for j in judged], top, tied)
        best = judged[top]
        kept = best[1]
        tried = tuple((name, *ratios) for name, _, ratios in judged)
        choice = SolidChoice(
            kept is not pres, other, tried, retr, self.spread, best[0] == THROUGH, seconds=secs
        )
        self._chosen[id(kept)] = (kept, choice, judged[first][2] if top != first else None)
        return kept


def describe(choice: SolidChoice) -> str:
    """The verdict's words for a choice: the layout kept and every layout's predicted ratios."""
    layout = THROUGH if choice.through else WHOLE
    if not choice.judged:
        return f"{layout} on every solid layer ({UNJUDGED})"
    figures = "; ".join(figure(*t) for t in choice.tried)
    if choice.whole:
        kept = f"{layout} on every solid layer"
    else:
        kept = f"{choice.given_way} where the level sets gave way"
    why = f"; {settled(choice.retractions, choice.spread, choice.seconds)}" if choice.retractions else ""
    return f"{kept} (by loadpath compare's model over the slicer's file: {figures}{why})"
