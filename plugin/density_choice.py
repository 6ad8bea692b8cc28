"""``density = "auto"``: the density criterion chosen per part by the mechanics model's prediction.

No single criterion of :mod:`loadpath.density` is best on every part (``benchmarks/bench_sparse.py``,
PrusaSlicer gyroid 20 %, predicted failure load over the slicer's at the same mass): the energy
density gives the 3-point beam 1.88x and the shelf bracket 1.39x but makes the L-bracket weaker than
the slicer's file (0.85x, its top skin breaks at the inner corner); the ``"stack"`` criterion keeps
the bracket (1.02x) but gives the beam 1.31x and the shelf 1.00x.  So the run lays both and keeps the
one the model of ``loadpath compare`` (:func:`loadpath.stiffness.evaluate_file`: the beads as
printed, first-ply failure, the file's card) predicts better against the slicer's own file: first a
candidate that lays the slicer's plastic (:func:`mass_change` within :data:`MASS_TOLERANCE`, when no
fill was asked for), then one that loses neither stiffness nor failure load, then the largest
product of the two ratios (stiffness and strength weigh alike).

Why the mass comes first: with ``principal = "alternate"`` the ``"stack"`` field moves plastic from
each minor-stress layer to the major-stress layer above it, and only the pair keeps the mass.  Where
the minor layer's sparse paths come out too short to print (at its 8 mm pitch the bench's 12 mm
beam gets none) its block is kept as sliced, with the slicer's plastic, while its partner keeps the
extra: ``benchmarks/bench_printability.py --principal alternate``, 40 % files, sparse infill
1.27-1.88x the slicer's in the replaced blocks (PrusaSlicer L-bracket, swarm: four of eight layers
kept, +0.23 g), and the absolute ratios that ranked it first were bought with that plastic.  The verdict's figures are the kept candidate's
(:meth:`Judge.change`): the verdict uses the same model (:mod:`loadpath.stiffness.model`).  A
quicker prediction the verdict used to make (the engine's paths as beads every 0.5 mm on the run's
own mesh) ranked the bracket's two the other way (energy 1.077 / 0.950, stack 1.059 / 0.890, where
``compare`` finds 1.155 / 0.846 and 1.179 / 1.017).  Where the model is not run on every job (3D
parts) the first candidate is kept.

A near tie is settled at the printer (:func:`settle`).  The model's failure load of one part moves by
up to 6 % between layouts laid from fields that differ by round-off (:data:`SPREAD`), its stiffness
by well under 1 % (:data:`STIFFNESS_SPREAD`), so a candidate that ranks higher by less than that on
both is not known to be better; of two such, the one that prints with fewer retractions in the
replaced blocks is kept, on equal retractions the one whose replaced blocks print :data:`QUICKER`
quicker (:func:`printer_cost`), the higher-ranked one where they are not counted.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from loadpath.options import field

__all__ = [
    "CANDIDATES", "MASS_TOLERANCE", "SPREAD", "STIFFNESS_SPREAD", "Choice", "Judge", "score", "tie", "settle",
    "settled", "printer_cost", "QUICKER", "mass_change", "lays_sparse", "run_choosing",
    "judge", "describe", "figure",
]

CANDIDATES = ("energy", "stack")
"""The criteria ``density = "auto"`` lays and judges, in order (the first is kept without a prediction)."""

MASS_TOLERANCE = 0.02
"""Largest share by which a candidate may change the plastic of the infill it was to replace and still
lay the slicer's mass (issue 15: the total plastic within 2 % of the slicer's sparse infill)."""


SPREAD: float = field("tie_spread").default
"""Share by which the mechanics model's failure load of one part moves between layouts laid from
fields that differ by round-off: ``benchmarks/printability_results.md``, fifteenth round (the force
turned by 0.0003 to 0.001 rad, the 2.4 mm bent parts at 100 %: up to 5.6 %).  A candidate ranking
higher by less is in a tie (:func:`tie`); the setting ``tie_spread`` (its owner,
:mod:`loadpath.options`) sets another share for a run, 0 for the model's rank alone."""


@dataclass(frozen=True)
class Choice:
    """What ``density = "auto"`` tried and kept.

    Attributes
    ----------
    criterion : str
        The criterion kept.
    tried : tuple of (str, float or None, float or None)
        Per candidate: criterion, predicted stiffness ratio and failure-load ratio over the slicer's
        file (None: not predicted).
    off_mass : tuple of (str, float)
        The candidates that did not lay the slicer's mass (:func:`mass_change` beyond
        :data:`MASS_TOLERANCE`), with their change (a share: 0.12 is 12 % more plastic).
    retractions : tuple of (int or None)
        Per candidate of ``tried``, in its order, its retractions in the replaced blocks where a tie
        was settled by them (:func:`settle`); ``()`` where the model's ranks decided.
    spread : float
        The share within which ranks were a tie (setting ``tie_spread``).
    seconds : tuple of (float or None)
        Per candidate of ``tried``, as ``retractions``: the print time of its replaced blocks, s.
    """

    criterion: str
    tried: tuple[tuple[str, float | None, float | None], ...]
    off_mass: tuple[tuple[str, float], ...] = ()
    retractions: tuple[int | None, ...] = ()
    spread: float = SPREAD
    seconds: tuple[float | None, ...] = ()


def score(stiffness: float | None, failure: float | None, keeps_mass: bool = True) -> tuple[int, int, float]:
    """Rank of a candidate (larger is better): the slicer's mass first, no loss next, then
    ``stiffness * failure``.

    Parameters
    ----------
    stiffness, failure : float or None
        Predicted ratios over the slicer's file (1.0: unchanged); a missing failure ratio counts as 1.
    keeps_mass : bool
        Whether the candidate lays the plastic it was asked for (:func:`mass_change`).
    """
    if stiffness is None:
        return (int(keeps_mass), -1, 0.0)
    f = 1.0 if failure is None else failure
    return (int(keeps_mass), int(stiffness >= 1.0 and f >= 1.0), stiffness * f)


STIFFNESS_SPREAD = 0.01
"""The same for the predicted stiffness, a whole-part figure that moves far less: one layout of the
12 mm beam at PrusaSlicer 20 % (``benchmarks/printability_results.md``, sixteenth round), the force
turned by 0, +0.0003 and -0.001 rad: 1.386, 1.381 and 1.386x the slicer's (0.4 %), where its failure
load moved by 3.7 %."""

Ratios = tuple[float | None, float | None]
"""Predicted stiffness and failure-load ratios over the slicer's file (None: not predicted)."""


def tie(higher: Ratios, lower: Ratios, spread: float = SPREAD) -> bool:
    """Whether ``higher`` (stiffness, failure-load ratios) ranks above ``lower`` only by what the model
    does not resolve: its stiffness within :data:`STIFFNESS_SPREAD` of ``lower``'s and its failure load
    within ``spread`` (a share, :data:`SPREAD`; a missing one counts as 1; mass aside: callers compare
    candidates that both lay it).  False where either is not predicted or ``spread`` is 0."""
    if spread <= 0 or higher[0] is None or lower[0] is None or score(*higher) <= score(*lower):
        return False
    (s_h, f_h), (s_l, f_l) = higher, lower
    f_h, f_l = (1.0 if f is None else f for f in (f_h, f_l))
    return s_h <= s_l * (1.0 + STIFFNESS_SPREAD) and f_h <= f_l * (1.0 + spread)


QUICKER = 0.02
"""On equal retractions, a tied result whose replaced blocks print at least this share quicker than
the one ranked highest is kept (:func:`settle`).  CuraEngine combs inside the infill and retracts
nowhere there, so on its files retractions never settled a tie: on the bench's L-bracket at
CuraEngine 100 % (``benchmarks/bench_printability.py``) the swarm ranked 0.3 % above the level sets
and was kept, with 551 s in the replaced blocks against 482 s and twice their travel."""


def printer_cost(pres: Any) -> tuple[int, float | None] | None:
    """Retractions and kinematic print time (s; None where not timed) of a run's replaced blocks
    (:func:`loadpath.printability.verdict_counts`), or None where they are not counted."""
    from loadpath.printability import verdict_counts

    counts, _ = verdict_counts(pres)
    if counts is None:
        return None
    own = counts["loadpath"]
    secs = own.get("print_s")
    return int(own["retractions"]), None if secs is None else float(secs)


def settle(
    results: Sequence[Any], top: int, tied: Sequence[int]
) -> tuple[int, tuple[int | None, ...], tuple[float | None, ...]]:
    """A tie settled at the printer: which of the results tied with the one ranked highest is kept.

    Parameters
    ----------
    results : sequence of PipelineResult
    top : int
        The one ranked highest.
    tied : sequence of int
        Those in a :func:`tie` with it.

    Returns
    -------
    kept : int
        The one of ``top`` and ``tied`` that prints with the fewest retractions in the replaced
        blocks; among those with as few, ``top`` (else the first of ``tied``) unless another prints
        them :data:`QUICKER` quicker (then the quickest).  ``top`` where any result is not counted
        (the higher rank stands).
    counts : tuple of (int or None)
        Every result's retractions, in the order given.
    seconds : tuple of (float or None)
        Every result's print time of its replaced blocks, s.
    """
    costs = [printer_cost(r) for r in results]
    n = tuple(None if c is None else c[0] for c in costs)
    secs = tuple(None if c is None else c[1] for c in costs)
    if None in n:
        return top, n, secs
    pool = [k for k in (top, *tied) if n[k] == min(n[j] for j in (top, *tied))]
    kept = pool[0]
    if all(secs[k] is not None for k in pool):
        quickest = min(pool, key=lambda k: secs[k])
        if secs[quickest] < (1.0 - QUICKER) * secs[kept]:
            kept = quickest
    return kept, n, secs


def lays_sparse(pres: Any) -> bool:
    """Whether a pipeline result laid any sparse infill (a job on a unit of kind ``"sparse"``)."""
    return any(jr.job.unit.kind == "sparse" for jr in getattr(pres, "jobs", ()))


def mass_change(pres: Any) -> float | None:
    """The plastic a run adds to the infill it was to replace, as a share of the slicer's.

    Summed over the blocks it replaced (new filament minus old) and divided by the slicer's filament
    of those and of the blocks it kept as sliced (``SpliceResult.skipped``: they keep the slicer's
    plastic, which a ``"stack"`` pair had moved to the other layer).  None when nothing was replaced.
    """
    sp = getattr(pres, "splice", None)
    if sp is None or not sp.blocks:
        return None
    added = sum(b.filament_new - b.filament_old for b in sp.blocks)
    old = sum(b.filament_old for b in sp.blocks) + sum(pres.program.block(i).e for i, _ in sp.skipped)
    return float(added / old) if old > 0 else None


def run_choosing(
    run: Callable[[Any], Any],
    predict: Callable[[Any], tuple[float, float | None] | None],
    options: Any,
    spread: float = SPREAD,
    rank_by: Callable[[Any], tuple[float, float | None] | None] | None = None,
) -> tuple[Any, Choice]:
    """Run the pipeline once per candidate and keep the better one (module docstring).

    Parameters
    ----------
    run : callable
        ``run(pipeline_options) -> PipelineResult``.
    predict : callable
        ``predict(pipeline_result) -> (stiffness ratio, failure-load ratio) or None``: the result's
        figures over the slicer's file (:func:`judge`), None where they cannot be predicted.
    options : PipelineOptions
        With ``density`` set (its criterion is replaced by each candidate's).  Where its ``fill`` is
        set (the user asked for another mass) the mass does not rank the candidates.
    spread : float
        Ties within this share of failure load go to fewer retractions (:func:`tie`, :func:`settle`).
    rank_by : callable or None
        ``rank_by(pipeline_result) -> ratios or None``: where a candidate's run kept a layout from a
        tie at the printer with the one its model ranked first
        (:meth:`loadpath.plugin.solid_choice.SolidChooser.ranked`), that one's ratios, which rank
        the candidate (None: its own).  So the candidates are ranked as the model ranks them, and
        each prints the layout its own tie settled; a candidate below the best is in a tie with it
        only where the layout it prints is (a tie's spread is not passed on from one tie to the
        next).

    Returns
    -------
    result : PipelineResult
    choice : Choice or None
        None where the first candidate laid no sparse infill (:func:`lays_sparse`: a file printed
        solid): every candidate would lay the same, so none other is laid and nothing is chosen.
    """
    ranked = []  # (rank, -order, result, criterion, ratios, keeps mass, its own ratios)
    tried: list[tuple[str, float | None, float | None]] = []
    off: list[tuple[str, float]] = []
    own_mass = getattr(options.density, "fill", None) is None
    for i, crit in enumerate(CANDIDATES):
        pres = run(replace(options, density=replace(options.density, criterion=crit)))
        if i == 0 and not lays_sparse(pres):
            return pres, None
        own = ratios = predict(pres) if pres.changed else None
        if ratios is not None and rank_by is not None:
            ratios = rank_by(pres) or ratios
        share = mass_change(pres) if own_mass else None
        keeps = share is None or abs(share) <= MASS_TOLERANCE
        if not keeps:
            off.append((crit, float(share)))
        tried.append((crit, *(ratios or (None, None))))
        if ratios is None and i > 0:
            continue  # not judged: not kept
        got = ratios or (None, None)
        ranked.append((score(*got, keeps), -i, pres, crit, got, keeps, own or got))
        if ratios is None:
            break  # nothing replaced or nothing to judge by: the first candidate stands
    ranked.sort(key=lambda r: r[:2], reverse=True)  # higher rank first; on equal ranks the earlier
    best = ranked[0]
    retr: tuple[int | None, ...] = ()
    secs: tuple[float | None, ...] = ()
    # a tie within the model's spread: the printer decides.  What the second would print is what
    # must lie within the spread of the best (ties do not chain: each candidate's own is one already)
    if len(ranked) > 1 and ranked[1][5] == best[5] and tie(best[4], ranked[1][6], spread):
        kept, n, t = settle([best[2], ranked[1][2]], 0, [1])
        order = [c for c, *_ in tried]
        retr = tuple(n[0] if c == best[3] else n[1] for c in order)
        secs = tuple(t[0] if c == best[3] else t[1] for c in order)
        best = ranked[kept]
    return best[2], Choice(best[3], tuple(tried), tuple(off), retr, spread, secs)


def figure(name: str, stiffness: float | None, failure: float | None) -> str:
    """One candidate's predicted ratios in the verdict's words (``name stiffness 1.155x, failure load 0.846x``)."""
    if stiffness is None:
        return f"{name} not predicted"
    return f"{name} stiffness {stiffness:.3f}x, failure load " + (
        "not predicted" if failure is None else f"{failure:.3f}x"
    )


def describe(choice: Choice) -> str:
    """The verdict's words for a choice: the criterion kept and every candidate's predicted ratios.

    These are the figures of ``loadpath compare``'s model that made the choice; the verdict's
    stiffness and failure-load change are the kept candidate's (the same model, :meth:`Judge.change`).
    """
    figures = "; ".join(figure(crit, s, f) for crit, s, f in choice.tried)
    if all(s is None for _, s, _ in choice.tried):
        return f"'{choice.criterion}' (auto: nothing to judge by, the first candidate kept)"
    off = "".join(
        f"; {crit} laid {share:+.0%} of the slicer's plastic (blocks kept as sliced), not its mass"
        for crit, share in choice.off_mass
    )
    tied = f"; {settled(choice.retractions, choice.spread, choice.seconds)}" if choice.retractions else ""
    model = "auto, by loadpath compare's model over the slicer's file"
    return f"'{choice.criterion}' ({model}: {figures}{off}{tied})"


def settled(
    counts: tuple[int | None, ...], spread: float = SPREAD, seconds: tuple[float | None, ...] = ()
) -> str:
    """The verdict's words for a tie settled at the printer (``counts``: each layout's retractions,
    in the order the figures name them; ``spread``: the share within which the ranks tied;
    ``seconds``: each one's print time of the replaced blocks, where counted)."""
    head = f"a tie within the model's {spread:.0%} spread"
    if None in counts:
        return f"{head}: retractions not counted, the higher rank kept"
    if len(set(counts)) == 1:
        if len(seconds) == len(counts) and None not in seconds:
            times = " against ".join(f"{t:.0f} s" for t in seconds)
            return f"{head}, {counts[0]} retractions each: print time {times}"
        return f"{head}, {counts[0]} retractions each: the higher rank kept"
    return f"{head}: retractions " + " against ".join(map(str, counts))


class Judge:
    """``predict`` for :func:`run_choosing`: the model of ``loadpath compare`` on the slicer's program
    and each candidate's output.

    Only plate (2D) analyses are judged: a 3D body's prediction samples every layer into
    tetrahedra (minutes on a tall part), so there the first candidate stands.  What it evaluated
    stays for the verdict (:meth:`change`): the kept candidate's figures are the verdict's, with no
    further solve.

    With the run's cache (and a cache key for every body's analysis), each file is predicted as the
    verdict predicts one (:func:`loadpath.stiffness.change.predicted_change`, the same model and
    figures): every prediction is kept, so a run of the same file again, or of a re-slice that lays
    the same material (:mod:`loadpath.stiffness.near`), judges its candidates from the cache (issue
    17: the sparse gusset run again in process, 5.9 -> 2.2 s; re-sliced at other speeds, 4.7 -> 2.6 s).  Without one, each candidate and the
    slicer's file once (:func:`loadpath.stiffness.evaluate_file`, one mesh for all).
    """

    def __init__(
        self,
        program: Any,
        loadcase: Any,
        workers: int = 1,
        progress: Callable[[str, int, int], None] | None = None,
        cache: Any = None,
    ) -> None:
        self.program = program
        self.loadcase = loadcase
        self.workers = workers
        self.progress = progress  # ``progress("judge", done, total)`` around each evaluation
        self.cache = cache
        self.meshes: dict = {}
        self.ref: Any = None
        # id(result) -> (weakref, FileResult or StiffnessChange, seconds)
        self._seen: dict[int, tuple[Any, Any, float]] = {}

    def __call__(self, pres: Any) -> tuple[float, float | None] | None:
        import time
        import weakref

        if any(getattr(an, "analysis", "2d") != "2d" for an in pres.analyses.values()):
            return None
        seen = self._judged(pres)
        if seen is not None:  # judged before: its figures
            return self._ratios(seen[0])
        t0 = time.perf_counter()
        if self.progress:
            self.progress("judge", 0, 1)
        if self.cache is not None and pres.fea_keys and set(pres.fea_keys) >= set(pres.analyses):
            res = self._predicted(pres)
        else:
            res = self._evaluated(pres)
        self._seen[id(pres)] = (weakref.ref(pres), res, time.perf_counter() - t0)
        if self.progress:
            self.progress("judge", 1, 1)
        return self._ratios(res)

    def _evaluated(self, pres: Any) -> Any:
        """``compare``'s :class:`~loadpath.stiffness.compare.FileResult` of a result's output (the
        slicer's file evaluated once, beside the first candidate where there are two workers)."""
        from loadpath.gcode import parse
        from loadpath.procs import fork_map, forks
        from loadpath.stiffness.compare import evaluate_file

        out = parse(pres.data, strict=False)
        if self.ref is None and forks(self.workers, 2):
            # the slicer's file and the first candidate side by side: the same computations in two
            # forked workers (the sparse gusset's first judgment 1.6 -> 0.9 s); the later
            # candidates mesh the body again here (0.08 s)
            _EVALUATE[:] = [(self.program, self.loadcase, "slicer"), (out, self.loadcase, "candidate")]
            try:
                self.ref, res = fork_map(_evaluate_nth, [0, 1], 2)
            finally:
                _EVALUATE.clear()
            return res
        if self.ref is None:
            self.ref = evaluate_file(
                self.program, self.loadcase, meshes=self.meshes, name="slicer", metrics=False
            )
        return evaluate_file(out, self.loadcase, meshes=self.meshes, name="candidate", metrics=False)

    def _predicted(self, pres: Any) -> Any:
        """The verdict's :class:`~loadpath.stiffness.change.StiffnessChange` of a result, its predictions
        read from the run's cache or solved and kept there (no budget: every 2D part is judged)."""
        from loadpath.stiffness.change import predicted_change

        return predicted_change(
            pres.analyses,
            self.program,
            lambda: pres.output,  # parsed once, kept on the result (the verdict's counts read it too)
            {o.name: o.code for o in pres.geometry.objects},
            pres.geometry.filament_diameter,
            loadcase=self.loadcase,
            cache=self.cache,
            fea_keys=pres.fea_keys,
            budget=float("inf"),
            workers=self.workers,
        )

    def _ratios(self, res: Any) -> tuple[float, float | None]:
        """Stiffness and failure-load ratios of an evaluated candidate over the slicer's file."""
        from loadpath.stiffness.change import StiffnessChange
        from loadpath.stiffness.compare import row

        if isinstance(res, StiffnessChange):
            fail = res.failure_load
            known = fail is not None and fail == fail
            return 1.0 + float(res.absolute), (1.0 + float(fail) if known else None)
        r = row(res, self.ref)
        fail = r.relative_failure_load
        return float(r.relative_stiffness), (float(fail) if fail == fail else None)

    def change(self, pres: Any) -> Any:
        """The verdict's :class:`~loadpath.stiffness.change.StiffnessChange` of a result this judged, or None.

        The same figures :func:`~loadpath.stiffness.change.predicted_change` would compute for it
        (both are ``compare``'s model on the slicer's file and the output's beads; the verdict line
        the run inserts is a comment, no bead).
        """
        from loadpath.stiffness.change import StiffnessChange, change_from_results

        seen = self._judged(pres)
        if seen is None:
            return None
        if isinstance(seen[0], StiffnessChange):  # predicted as the verdict predicts
            return seen[0]
        return change_from_results(self.ref, *seen)

    def _judged(self, pres: Any) -> tuple[Any, float] | None:
        """``(FileResult or StiffnessChange, seconds)`` of a result this judged (the same object, not
        one with its id), or None."""
        seen = self._seen.get(id(pres))
        if seen is None or seen[0]() is not pres:
            return None
        return seen[1], seen[2]


_EVALUATE: list[tuple[Any, Any, str]] = []
"""``(program, load case, name)`` of the files :class:`Judge` evaluates in forked workers."""


def _evaluate_nth(k: int) -> Any:
    from loadpath.stiffness.compare import evaluate_file

    source, loadcase, name = _EVALUATE[k]
    return evaluate_file(source, loadcase, name=name, metrics=False)


def judge(
    program: Any,
    loadcase: Any,
    workers: int = 1,
    progress: Callable[[str, int, int], None] | None = None,
    cache: Any = None,
) -> Judge:
    """The :class:`Judge` of the slicer's program under a load case (``workers``: processes for its
    first judgment, the slicer's file and the first candidate side by side; ``progress``: told of
    each evaluation as stage ``"judge"``; ``cache``: the run's, where its predictions are kept)."""
    return Judge(program, loadcase, workers, progress, cache)
