"""One job: a G-code file and a load case in, the processed file (and a report) out, safely.

This is what every front end calls (``loadpath run``, ``loadpath demo``, the PrusaSlicer hook, the
Cura plugin through the command line, batch and serve)::

    from loadpath.plugin.job import JobRequest, run_job
    result = run_job(JobRequest(Path("part.gcode"), Path("case.toml"), cli={"engine": "swarm"}))
    result.output, result.warnings

Guarantees (interface.md, "Exit status"): everything that can fail (engines, splice, check, the
verdict, the report's data and figures) runs first; the output is then written to a temporary file
in the target folder and renamed over the target, so the input (and an existing output) is never
left half-written, and on any failure the input is untouched and no output written.  Every failure
message ends with what became of the files (:func:`fate`).  Only the report's files and the run log
(``$XDG_STATE_HOME/loadpath/runs.log``) are written after the G-code; their failure is a warning.
With ``on_failure = "keep"`` a failure becomes a warning and the slicer's G-code is kept (copied to
the output when the output is another file).  Binary G-code is written back as binary G-code.  A
file whose header carries loadpath's verdict line is refused unless ``force``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import secrets
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from loadpath import engines
from loadpath.density import DensityOptions
from loadpath.errors import InternalError, LoadpathError, SettingsError, showing_tracebacks
from loadpath.files import check_output, kind_of, read_regular, same_file, write_target
from loadpath.plugin import settings as settings_mod
from loadpath.plugin.density_choice import CANDIDATES, MASS_TOLERANCE, describe, judge, mass_change, run_choosing
from loadpath.plugin.solid_choice import SolidChooser
from loadpath.plugin.solid_choice import describe as describe_solid
from loadpath.plugin.lifecycle import note_written
from loadpath.plugin.job_record import already_processed, fate, log, own_warnings, with_header
from loadpath.printability import verdict_counts

__all__ = ["JobRequest", "JobResult", "run_job", "default_output", "write_atomic", "infer_cura_filament"]


@dataclass(frozen=True)
class JobRequest:
    """What to do.

    Attributes
    ----------
    input : Path
        The slicer's G-code (text or binary).
    loadcase : Path
        The load case TOML.
    output : Path or None
        Default: next to the input as ``IN.loadpath.gcode`` (``.bgcode`` for binary files).
    in_place : bool
        Rewrite the input itself (atomically).
    report : Path or None
        Folder for the HTML report and ``metrics.json``.
    cli : mapping
        Settings given on the command line (field -> value).
    slicer_settings : Path or None
        The slicer's settings as JSON (Cura's keys; the Cura plugin writes it).
    env : mapping or None
        Environment to read ``SLIC3R_*`` from (the PrusaSlicer hook passes ``os.environ``).
    analyze : callable or None
        Replaces :func:`loadpath.fea.analyze` (see :func:`loadpath.pipeline.run`).
    cache : loadpath.cache.Cache or None
        The cache of analyses and paths (the local service passes its own); None: the user's
        (:func:`loadpath.cache.default_folder`) unless the setting ``cache`` is off, then one in a
        temporary folder for this run alone (its layouts share their analyses), deleted with it.
    force : bool
        Process a file loadpath already processed (refused otherwise: its header says so).
    predict : bool
        Predict the stiffness change for the verdict (two solves per body on the run's mesh).
    """

    input: Path
    loadcase: Path
    output: Path | None = None
    in_place: bool = False
    report: Path | None = None
    cli: Mapping[str, Any] = field(default_factory=dict)
    slicer_settings: Path | None = None
    env: Mapping[str, str] | None = None
    analyze: Callable[..., Any] | None = None
    force: bool = False
    predict: bool = True
    cache: Any = None


@dataclass
class JobResult:
    """What happened.

    Attributes
    ----------
    output : Path
        Where the result is (the input itself when in place).
    written : bool
        A file was written.
    changed : bool
        Infill was replaced (False: the slicer's G-code came back unchanged).
    warnings : list of str
    error : str or None
        The failure that ``on_failure = "keep"`` turned into a warning.
    pipeline : PipelineResult or None
    settings : Settings or None
    times : dict of str -> float, s
        Per stage: parse, geometry, loadcase, fea, paths, splice, check, write, report.
    report : Path or None
        The report's HTML page.
    verdict : Verdict or None
        What the run did and gained (:mod:`loadpath.verdict`); also for a failure kept with
        ``on_failure = "keep"``.
    cache : loadpath.cache.Cache or None
        The cache the run used (its ``stats`` count hits and misses).
    density : Choice or None
        With ``density = "auto"`` and sparse infill replaced: the criteria tried, their predicted
        ratios and the one kept (:mod:`loadpath.plugin.density_choice`).
    solid : SolidChoice or None
        Where the level sets gave way on solid infill (no engine named): both layouts' predicted
        ratios and the one kept (:mod:`loadpath.plugin.solid_choice`).
    """

    output: Path
    written: bool = False
    changed: bool = False
    warnings: list[str] = field(default_factory=list)
    error: str | None = None
    pipeline: Any = None
    settings: Any = None
    times: dict[str, float] = field(default_factory=dict)
    report: Path | None = None
    verdict: Any = None
    cache: Any = None
    density: Any = None
    solid: Any = None


def default_output(path: Path) -> Path:
    """``part.gcode`` -> ``part.loadpath.gcode`` (``part.bgcode`` -> ``part.loadpath.bgcode``)."""
    suffix = path.suffix if path.suffix else ".gcode"
    return path.with_name(f"{path.stem}.loadpath{suffix}")


def write_atomic(path: Path, data: bytes, mode_like: Path | None = None) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename.

    The file keeps the permission bits of ``path`` if it exists, else takes those of ``mode_like``
    (the input G-code) if given, else the umask default (``0o666 & ~umask``, what the user's own
    tools would create); never ``mkstemp``'s 0600.  A symlink is followed: its target is replaced and
    the link kept.
    """
    path = write_target(path)  # through a symlink: rewrite its target, keep the link
    folder = path.parent if str(path.parent) else Path(".")
    mode = next(
        (Path(p).stat().st_mode & 0o7777 for p in (path, mode_like) if p is not None and Path(p).is_file()),
        None,
    )
    try:
        fd, tmp = _create_temp(folder, path.name)
    except OSError as exc:
        raise SettingsError(
            f"cannot write into {str(folder)!r}: {exc.strerror or exc}; choose another output folder with -o"
        ) from exc
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
        note_written(path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise SettingsError(
            f"cannot write {str(path)!r}: {exc.strerror or exc}; check the folder's permissions "
            "and free space"
        ) from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _create_temp(folder: Path, name: str) -> tuple[int, str]:
    """Create a hidden file next to the target, mode 0o666 so the kernel applies the umask (not 0600)."""
    for _ in range(100):
        tmp = str(folder / f".{name}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary name next to {name!r} in {str(folder)!r}")


def infer_cura_filament(program, geo) -> float | None:
    """Filament diameter measured on a settings-less file's solid infill, mm, or None.

    The rule is core's (:func:`loadpath.geometry.flow.solid_infill_diameter`); kept under this
    name for callers of the application layer.
    """
    from loadpath.geometry.flow import solid_infill_diameter

    return solid_infill_diameter(program, geo)


def run_job(request: JobRequest, progress: Callable[[str, int, int], None] | None = None) -> JobResult:
    """Run one job (see the module docstring).

    Everything that can fail (parse, engines, splice, check, verdict, the report's data and
    figures) runs before the output is renamed into place; only the report's files and the run
    log are written after it, and their failure is a warning that says the G-code was written.
    Every failure message ends with what became of the input and the output (:func:`fate`).

    ``progress(stage, done, total)`` hears each stage of every layout laid; before each layout,
    ``progress("layout", k, 0)`` numbers it (1, 2, ...: ``density = "auto"`` and the solid choice
    lay several and keep one).

    Raises
    ------
    LoadpathError
        On failure, unless ``on_failure`` is ``"keep"`` (then the result carries the error);
        :class:`~loadpath.errors.InternalError` for a bug or lack of memory.
    """
    inp = Path(request.input)
    out = inp if request.in_place else Path(request.output) if request.output else default_output(inp)
    result = JobResult(output=out)
    on_failure = str(request.cli.get("on_failure") or "fail")
    _check_paths(inp, out, request.in_place)  # before any work; never turned into "kept"
    try:
        with warnings.catch_warnings(record=True) as caught, contextlib.ExitStack() as scratch:
            # recorded, whatever filter the front end set (the CLI ignores library warnings so that
            # none reaches stderr as Python prints them): the run turns each into a line of its own
            warnings.simplefilter("default")
            for quiet in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
                warnings.simplefilter("ignore", quiet)  # Python's own defaults: not the user's concern
            result = _run(request, inp, out, result, progress, caught, scratch)
        result.warnings.extend(own_warnings(caught))
        if result.verdict is not None:
            w = log(f"{result.verdict.line()} [{inp}]")
            if w:
                result.warnings.append(w)
        return result
    except LoadpathError as exc:
        error, failed = str(exc).rstrip(". "), LoadpathError
    except MemoryError:
        error, failed = "out of memory; close other programs or process a smaller file", InternalError
    except Exception as exc:  # a bug: still one line, saying what became of the files
        if showing_tracebacks():
            raise  # interface.md: LOADPATH_DEBUG=1 shows the traceback (the CLI's catch-all re-raises it)
        error = (
            f"internal error ({type(exc).__name__}: {' '.join(str(exc).split())}); "
            "please report this with the G-code and load case (LOADPATH_DEBUG=1 shows where)"
        )
        failed = InternalError
    keep = on_failure == "keep" or (result.settings is not None and result.settings.on_failure == "keep")
    if not keep:
        log(f"loadpath failed: {error}; {fate(inp, out, result.written)} [{inp}]")
        raise failed(f"{error}; {fate(inp, out, result.written)}")
    from loadpath import verdict as verdict_mod

    result.error = error
    # an input loadpath already processed is not the slicer's G-code: say "the input's"
    whose = "the input" if error.startswith("already processed") else "the slicer's G-code"
    if not same_file(out, inp) and inp.is_file() and not result.written:
        write_atomic(out, read_regular(inp), mode_like=inp)
        result.written = True
        kept = f"{str(out)!r} is a copy of {whose}; the input is untouched"
    elif result.written:
        kept = fate(inp, out, True)
    else:
        kept = f"{whose} {str(inp)!r} is untouched"
    result.warnings.append(f"kept {whose}: {error}; {kept}")
    result.changed = False
    result.verdict = verdict_mod.build(
        None, str(request.cli.get("engine") or "?"), 1.75, len(result.warnings), note=f"failed: {error}"
    )
    log(f"{result.verdict.line()} [{inp}]")
    return result


def _check_paths(inp: Path, out: Path, in_place: bool) -> None:
    """Refuse an input that is no regular file and an output that may not be written (one line each)."""
    kind = kind_of(inp)
    if kind == "missing":
        raise SettingsError(f"G-code file {str(inp)!r} does not exist; check the path")
    if kind is not None:
        raise SettingsError(f"G-code file {str(inp)!r} is {kind}, not a file; give the path of a .gcode file")
    why = check_output(out, None if in_place else inp, in_place)
    if why:  # before any work: nothing was read or written
        raise SettingsError(f"{why}; {fate(inp, inp if same_file(out, inp) else out, False)}")


def predicted_loss(stiff) -> str:  # type: ignore[no-untyped-def]
    """A warning when the model predicts the new infill worse than the slicer's, beyond what it
    resolves (:data:`~loadpath.plugin.density_choice.STIFFNESS_SPREAD`, ``SPREAD``) and not made up
    by a gain in the other figure; "" otherwise (or when nothing was predicted)."""
    from loadpath.plugin.density_choice import SPREAD, STIFFNESS_SPREAD
    from loadpath.verdict import signed

    if stiff is None:
        return ""
    k, f = stiff.same_mass, stiff.failure_load_same_mass
    softer = k < -STIFFNESS_SPREAD and not (f is not None and f > SPREAD)
    weaker = f is not None and f < -SPREAD and not k > STIFFNESS_SPREAD
    if not (softer or weaker):
        return ""
    what = "less stiff and weaker" if softer and weaker else "less stiff" if softer else "weaker"
    figures = f"stiffness {signed(100 * k)}%"
    if f is not None:
        figures += f", failure load {signed(100 * f)}%"
    return (
        f"the mechanics model predicts the new infill {what} than the slicer's ({figures} at the same mass): "
        "print the slicer's G-code instead, or try another engine or principal stress"
    )


def _prediction(pres, warnings: list[str], cache=None, loadcase=None, known=None, workers: int = 1):
    """The predicted stiffness and failure-load change and, when there is none, why (a warning when the model failed).

    The model of ``loadpath compare`` (:mod:`loadpath.stiffness.model`) on the slicer's file and the
    run's output, so the verdict says what ``compare`` says of the same two files; ``known``: that
    change already computed (``density = "auto"`` or the solid layout's choice judged the kept result
    with it), used as is;
    ``workers``: processes for the two predictions of a body (the run's ``jobs``).

    Only 2D (plate) analyses of at most :data:`~loadpath.stiffness.change.VERDICT_SAMPLES` bead
    samples are predicted on every run: two solves with the beads sampled every 0.1 mm (the
    100-layer specimen's 80 million took 30-60 s each; the verdict says so, no warning).  A 3D
    body's prediction samples every layer into tetrahedra: on a 120-layer twisted tower (46 000
    elements) it took 520 s, longer than the run, so the verdict says so and points to
    ``loadpath compare``, which predicts the same.
    """
    from loadpath.errors import LoadpathError as _Err
    from loadpath.stiffness.change import TooCostly, predicted_change

    if any(getattr(an, "analysis", "2d") != "2d" for an in pres.analyses.values()):
        return None, "3D part, not predicted on every run: loadpath compare IN OUT --loadcase CASE predicts it"
    if known is not None:
        return known, ""
    try:
        return predicted_change(
            pres.analyses,
            pres.program,
            lambda: pres.output,  # parsed only for a part within the budget (and kept: the counts)
            {o.name: o.code for o in pres.geometry.objects},
            pres.geometry.filament_diameter,
            loadcase=loadcase,
            cache=cache,
            fea_keys=pres.fea_keys,
            workers=workers,
        ), ""
    except TooCostly as exc:
        return None, f"{exc}: loadpath compare IN OUT --loadcase CASE predicts it"
    except (_Err, ValueError, FloatingPointError, np_error()) as exc:
        warnings.append(f"no stiffness prediction ({type(exc).__name__}: {' '.join(str(exc).split())})")
        return None, "the model failed; see the warnings"


def np_error() -> type[Exception]:
    """numpy's linear-algebra error (imported lazily)."""
    import numpy as np

    return np.linalg.LinAlgError


def _run(
    request: JobRequest,
    inp: Path,
    out: Path,
    result: JobResult,
    progress: Callable[[str, int, int], None] | None,
    caught: list | None,
    scratch: contextlib.ExitStack,
) -> JobResult:
    from loadpath import gcode, loadcase, pipeline
    from loadpath import verdict as verdict_mod
    from loadpath.pipeline.paths import default_workers

    times = result.times
    t = time.perf_counter()
    lc = loadcase.read(request.loadcase)
    program, container = gcode.read_container(inp)
    done = already_processed(program)
    if done is not None and not request.force:
        raise SettingsError(
            f"already processed by loadpath {done[0]} on {done[1]}; run it on the slicer's file, or pass --force"
        )
    cura = settings_mod.read_cura_settings(request.slicer_settings) if request.slicer_settings else None
    s = settings_mod.resolve(
        program, env=request.env, cura_settings=cura, toolpath=lc.toolpath, cli=request.cli
    )
    result.settings = s
    times["parse"] = time.perf_counter() - t

    if s.source("filament_diameter") == "default" and program.dialect.family == "cura":
        from loadpath import geometry

        d = infer_cura_filament(program, geometry.layer_geometry(program, check=False))
        bounds = settings_mod.schema_field("filament_diameter")
        if d is not None and bounds.minimum <= d <= bounds.maximum:  # else a measure gone wrong: the default
            s = s.with_values({"filament_diameter": d}, "inferred from the G-code")
            result.settings = s

    def params_of(engine: str) -> dict[str, Any]:  # the user's settings the engine takes (K, ...)
        return {name: getattr(s, name) for name in engines.get(engine).settings}

    sparse = s.engine_for_sparse()
    first = s.engine_first_on_solid()
    opts = pipeline.PipelineOptions(
        engine=s.engine,
        engine_params=params_of(s.engine),
        sparse_engine=sparse,
        sparse_engine_params=params_of(sparse),
        solid_first=first[0] if first else None,
        solid_first_params=first[1] if first else {},
        pitch=s.pitch,
        principal=s.principal,
        cross_angle=s.cross_angle,
        replace=tuple(s.replace),
        stagger=s.stagger,
        link=s.link,
        workers=s.jobs or default_workers(),
        check=s.check,
        density=DensityOptions(
            CANDIDATES[0] if s.density == "auto" else s.density,
            s.density_exponent,
            fill=s.sparse_fill,
            max_pitch=s.density_max_pitch,
        ),
    )
    from loadpath.cache import Cache

    if s.cache:
        cache = request.cache if request.cache is not None else Cache()
    else:
        # nothing from earlier runs and nothing kept, but a cache for this run alone: the solid and
        # density choices lay a part up to three times, and each lay solved its stress analysis
        # and laid its paths again (the printability bench's taper at 100 %: 62 s of CPU against
        # 40 s on a fresh cache, the same output); deleted with the run (``scratch``)
        import tempfile

        cache = Cache(Path(scratch.enter_context(tempfile.TemporaryDirectory(prefix="loadpath-run-"))))
    result.cache = cache
    laid = [0]

    def run_with(o: pipeline.PipelineOptions) -> pipeline.PipelineResult:
        laid[0] += 1
        if progress is not None:  # the layouts a run lays and judges, numbered (run_job)
            progress("layout", laid[0], 0)
        return pipeline.run(
            program, lc, o, settings_mod.splice_options(s), progress=progress, cura_settings=cura,
            analyze=request.analyze, cache=cache,
        )

    # where the level sets give way on solid infill, both layouts are laid and judged (solid_choice)
    judged = judge(program, lc, opts.workers, progress, cache)
    if s.density == "auto" and "sparse" in s.replace:  # lay each candidate, keep the better (density_choice)
        # each candidate's solid tie is settled inside it, the candidates ranked by the layouts the
        # model ranked first (solid_choice)
        chooser = SolidChooser(run_with, judged, s.tie_spread)
        pres, result.density = run_choosing(chooser, judged, opts, s.tie_spread, chooser.ranked)
    else:
        chooser = SolidChooser(run_with, judged, s.tie_spread)
        pres = chooser(opts)
    result.solid = chooser.choice(pres)
    result.pipeline = pres
    times.update(pres.times)
    result.warnings.extend(pres.warnings)
    result.changed = pres.changed
    share = mass_change(pres) if "sparse" in s.replace and s.sparse_fill is None else None
    if share is not None and abs(share) > MASS_TOLERANCE:  # a "stack" pair broken by a block kept as sliced
        result.warnings.append(
            f"the replaced infill has {share:+.0%} of the slicer's plastic, not its mass "
            f"({len(pres.splice.skipped)} of its blocks kept as sliced); try --set density=energy"
        )

    # the verdict (cheap but for the stiffness prediction) and the report are made before the
    # output is written: a failure of either costs nothing on disk
    t = time.perf_counter()
    asked = pres.changed and request.predict
    known = judged.change(pres) if asked else None
    stiff, why = _prediction(pres, result.warnings, cache, lc, known, opts.workers) if asked else (None, "")
    loss = predicted_loss(stiff)
    if loss:
        result.warnings.append(loss)
    # the printability counts reuse the output the prediction parsed; the report shows the same
    counts, counts_why = verdict_counts(pres)
    if counts is not None:  # the print time with the firmware's acceleration and jerk, everywhere
        from loadpath.splice.splicer import retimed

        dt = counts["loadpath"]["print_s"] - counts["slicer"]["print_s"]
        sres = retimed(pres.program, pres.splice, dt)
        parsed = vars(pres).get("output")  # the same moves: only comment lines changed
        pres = dataclasses.replace(pres, data=sres.data, splice=sres)
        if parsed is not None:
            vars(pres)["output"] = parsed
        result.pipeline = pres
    times["verdict"] = time.perf_counter() - t
    report = None
    if request.report is not None:
        from loadpath.report import build_report

        t = time.perf_counter()
        report = build_report(pres, s, times, source=inp.name, printability=counts)
        result.warnings.extend(report.warnings)
        times["report"] = time.perf_counter() - t
    result.warnings.extend(own_warnings(caught if caught is not None else []))
    v = verdict_mod.build(
        pres,
        s.engine,
        s.filament_diameter,
        len(result.warnings),
        stiffness=stiff,
        note=why,
        total_seconds=verdict_mod.total_print_seconds(pres.data) if pres.changed else None,
    )
    if not request.predict and pres.changed:
        v = dataclasses.replace(v, note="not asked for")
    if result.density is not None and "sparse" in v.kinds:  # no clause for sparse infill all kept as sliced
        v = dataclasses.replace(v, density=describe(result.density))
    if result.solid is not None and pres.changed:
        v = dataclasses.replace(v, solid=describe_solid(result.solid))
    if pres.changed:
        v = dataclasses.replace(v, printability=counts, printability_note=counts_why)
    result.verdict = v
    if report is not None:
        report.finish(v)

    t = time.perf_counter()
    if pres.changed:  # the verdict as the file's second line, an insertion the splice result records
        text = with_header(pres.data, verdict_mod.header_line(v))
        edits = tuple(sorted((*pres.splice.edits, (1, 1, 1))))
        pres = dataclasses.replace(pres, data=text, splice=dataclasses.replace(pres.splice, data=text, edits=edits))
        result.pipeline = pres
    data = (
        gcode.encode_like(container, pres.data)
        if pres.changed
        else program.to_bytes()
        if container is None
        else read_regular(inp)
    )
    if pres.changed or not same_file(out, inp):
        write_atomic(out, data, mode_like=inp)
        result.written = True
    times["write"] = time.perf_counter() - t
    if report is not None:
        try:
            result.report = report.write(Path(request.report))
        except OSError as exc:
            result.warnings.append(
                f"the report could not be written to {str(request.report)!r} ({exc.strerror or exc}); "
                f"the G-code {str(out)!r} was written"
            )
            # the file's header was final before this warning; the line on stderr and in the log count it
            result.verdict = dataclasses.replace(v, warnings=len(result.warnings))
    return result
