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

So where a job gave way, the run lays the part again with the level sets on every solid layer and
keeps the layout the model of ``loadpath compare`` predicts better, ranked as ``density = "auto"``
ranks its candidates (:func:`loadpath.plugin.density_choice.score`: no loss first, then stiffness
times failure load).  With ``density = "auto"`` the choice is made for each density candidate:
made once for the first and held for the second, it cost issue 15's 12 mm beam at PrusaSlicer 40 %
its failure load (3.329 -> 3.050x the slicer's) where the two layouts ranked the other way under
the second criterion; made for each, every layout the run chose from before is still among those
ranked.  A part the model does not judge on every run (3D analyses) keeps the swarm where the level
sets gave way.

A near tie is settled at the printer, as ``density = "auto"`` settles its own
(:func:`loadpath.plugin.density_choice.tie`): the model's failure load of one part moves by up to 6 %
between layouts laid from fields that differ by round-off, while the swarm's fragments cost three to
five times the level sets' retractions on the same files.  On the PrusaSlicer L-bracket above, one
run judged the level sets 1.008 / 0.925 and the swarm 1.007 / 0.954 and kept the swarm, with 485
retractions against the level sets' 149 (the slicer's: 25); the median of the three runs had ranked
them the other way.

With ``density = "auto"`` the layout is chosen within each density candidate by the model's rank
alone, and the tie is settled once, between the candidates
(:func:`loadpath.plugin.density_choice.run_choosing`): settled inside the ``stack`` candidate of
issue 15's 12 mm beam at PrusaSlicer 20 %, it gave that candidate the level sets' 1.361 / 1.748
instead of the swarm's 1.366 / 1.797, so ``energy`` ranked first with 503 retractions in the
replaced blocks, against 476 (and the higher failure load) kept otherwise.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from loadpath.plugin.density_choice import SPREAD, figure, score, settle, settled, tie

__all__ = ["SolidChoice", "SolidChooser", "gave_way", "describe"]


@dataclass(frozen=True)
class SolidChoice:
    """What the run laid on the solid layers where the level sets gave way, and why.

    Attributes
    ----------
    whole : bool
        True: the level sets on every solid layer were kept; False: the swarm where they gave way.
    given_way : str
        The engine the level sets gave way to.
    tried : tuple of (str, float, float or None)
        Per layout (``"level sets"``, then the engine given way to): predicted stiffness and
        failure-load ratios over the slicer's file.
    retractions : tuple of (int or None, int or None)
        Per layout, in the same order: retractions in its replaced blocks, where they settled a tie
        (:func:`loadpath.plugin.density_choice.settle`); ``()`` where the model's ranks decided.
    spread : float
        The share within which ranks were a tie (setting ``tie_spread``).
    """

    whole: bool
    given_way: str
    tried: tuple[tuple[str, float, float | None], ...]
    retractions: tuple[int | None, ...] = ()
    spread: float = SPREAD


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
        self, run: Callable[[Any], Any], predict: Callable[[Any], Any], spread: float = SPREAD
    ) -> None:
        self.run = run
        self.predict = predict
        self.spread = spread
        # id(kept result) -> (that result, the choice that kept it): held, so no other takes its id
        self._chosen: dict[int, tuple[Any, SolidChoice]] = {}

    def choice(self, pres: Any) -> SolidChoice | None:
        """The choice that kept ``pres`` (a result this returned), or None (nothing gave way)."""
        got = self._chosen.get(id(pres))
        return got[1] if got is not None and got[0] is pres else None

    def __call__(self, options: Any) -> Any:
        pres = self.run(options)
        other = gave_way(pres) if options.solid_first is not None and pres.changed else None
        if other is None:
            return pres
        split = self.predict(pres)
        if split is None:  # not judged (3D): the layers given way keep the other engine
            return pres
        whole = self.run(replace(options, solid_first_params={**options.solid_first_params, "give_way": False}))
        both = self.predict(whole) if whole.changed else None
        if both is None:
            return pres
        keep = score(*both) >= score(*split)
        retr: tuple[int | None, ...] = ()
        if not keep and tie(split, both, self.spread):  # within the model's spread: the printer decides
            keep, (n_split, n_whole) = settle(pres, whole)
            retr = (n_whole, n_split)
        kept = whole if keep else pres
        tried = (("level sets", *both), (other, *split))
        self._chosen[id(kept)] = (kept, SolidChoice(keep, other, tried, retr, self.spread))
        return kept


def describe(choice: SolidChoice) -> str:
    """The verdict's words for a choice: the layout kept and both layouts' predicted ratios."""
    figures = "; ".join(figure(*t) for t in choice.tried)
    kept = "level sets on every solid layer" if choice.whole else f"{choice.given_way} where the level sets gave way"
    why = f"; {settled(choice.retractions, choice.spread)}" if choice.retractions else ""
    return f"{kept} (by loadpath compare's model over the slicer's file: {figures}{why})"
