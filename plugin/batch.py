"""Many G-code files with one load case: in parallel processes, or on a Dask cluster.

Each file is one :func:`loadpath.plugin.job.run_job`; a failing file is recorded and the others go
on.  Locally the files are read and written in place by a process pool (one process per core by
default, one engine worker inside each); :mod:`loadpath.plugin.batch_cluster` runs the same tasks on a
Dask cluster (``--cluster tcp://host:8786``).

>>> tasks = plan(["parts/"], Path("case.toml"), cli={"engine": "swarm"})        # doctest: +SKIP
>>> results = run_local(tasks, workers=4)                                       # doctest: +SKIP
>>> print(table(results))                                                       # doctest: +SKIP
"""

from __future__ import annotations

import glob
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from loadpath.errors import LoadpathError, SettingsError
from loadpath.plugin.lifecycle import note_written

__all__ = [
    "Task",
    "FileResult",
    "plan",
    "find_inputs",
    "process",
    "run_local",
    "table",
    "metrics_summary",
    "BatchProgress",
    "SUFFIXES",
    "Progress",
]

SUFFIXES = (".gcode", ".bgcode", ".gco", ".g")
"""File endings taken from a folder."""


@dataclass(frozen=True)
class Task:
    """One file to process.

    Attributes
    ----------
    input, output : Path
    loadcase : Path
    cli : mapping
        Settings (field -> value) for :class:`~loadpath.plugin.job.JobRequest`.
    report : Path or None
        Folder for this file's report; None: none kept.
    metrics : bool
        Compute beta and coverage (the report's metrics, about a second per distinct layer).
    slicer_settings : Path or None
    force : bool
        Process files loadpath already processed (refused otherwise).
    """

    input: Path
    output: Path
    loadcase: Path
    cli: Mapping[str, Any] = field(default_factory=dict)
    report: Path | None = None
    metrics: bool = True
    slicer_settings: Path | None = None
    force: bool = False


@dataclass
class FileResult:
    """What happened to one file.

    Attributes
    ----------
    file : str
        The input path as given.
    status : {"ok", "unchanged", "kept", "failed"}
        ``unchanged``: nothing to replace (passed through); ``kept``: failed, slicer's G-code kept
        (``on_failure = keep``).
    seconds : float
    beta, coverage : float or None
        Stress alignment and coverage of the new paths, area-weighted over the distinct layers.
    output : str or None
    message : str
        The error, or the first warning.
    verdict : str
        The run's verdict line (:mod:`loadpath.verdict`) without its ``loadpath X on DATE:`` head.
    warnings : list of str
        Every warning of the run.
    """

    file: str
    status: str
    seconds: float
    beta: float | None = None
    coverage: float | None = None
    output: str | None = None
    message: str = ""
    verdict: str = ""
    warnings: list[str] = field(default_factory=list)

    @property
    def failed(self) -> bool:
        """Whether this file counts as a failure for the exit status."""
        return self.status == "failed"


# ---------------------------------------------------------------------------------------------- inputs


def _is_output(p: Path) -> bool:
    return ".loadpath." in p.name


def find_inputs(specs: Sequence[str]) -> list[Path]:
    """Files named by folders (their G-code files, not recursive) and glob patterns, sorted, unique.

    Earlier outputs (``*.loadpath.gcode``) are skipped.  Raises :class:`SettingsError` when a folder
    or pattern names no file.
    """
    found: dict[Path, None] = {}
    for spec in specs:
        p = Path(spec).expanduser()
        if p.is_dir():
            hits = sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in SUFFIXES)
        elif p.is_file():
            hits = [p]
        else:
            hits = sorted(Path(q) for q in glob.glob(str(p), recursive=True) if Path(q).is_file())
        hits = [q for q in hits if not _is_output(q)]
        if not hits:
            raise SettingsError(
                f"{spec!r} names no G-code file (folders are searched for "
                f"{', '.join('*' + s for s in SUFFIXES)}; quote glob patterns like 'parts/*.gcode')"
            )
        found.update(dict.fromkeys(hits))
    return list(found)


def plan(
    specs: Sequence[str],
    loadcase: Path,
    out_dir: Path | None = None,
    cli: Mapping[str, Any] | None = None,
    report_dir: Path | None = None,
    metrics: bool = True,
    slicer_settings: Path | None = None,
    force: bool = False,
) -> list[Task]:
    """Make the tasks: outputs named like ``loadpath run`` without ``-o``, or the input's name in ``out_dir``.

    Raises
    ------
    SettingsError
        No input; two inputs that would write the same output; an output that would overwrite an input.
    """
    from loadpath.plugin.job import default_output

    inputs = find_inputs(specs)
    if not Path(loadcase).is_file():
        raise SettingsError(f"load case {str(loadcase)!r} does not exist; check the path")
    cli = {"jobs": 1, **(cli or {})}  # files run in parallel: one engine worker inside each by default
    tasks: list[Task] = []
    seen: dict[Path, Path] = {}
    for inp in inputs:
        out = Path(out_dir) / inp.name if out_dir is not None else default_output(inp)
        key = out.resolve()
        if key in seen:
            raise SettingsError(
                f"{str(seen[key])!r} and {str(inp)!r} would both be written to {str(out)!r}; "
                "process them into different --out folders"
            )
        if key == inp.resolve():
            raise SettingsError(
                f"--out {str(out_dir)!r} is the folder of {str(inp)!r}: its output would overwrite "
                "it; choose another folder"
            )
        seen[key] = inp
        rep = Path(report_dir) / inp.name.rsplit(".", 1)[0] if report_dir is not None else None
        tasks.append(Task(inp, out, Path(loadcase), cli, rep, metrics, slicer_settings, force))
    return tasks


# ---------------------------------------------------------------------------------------------- one file


def metrics_summary(metrics: Mapping[str, Any]) -> tuple[float | None, float | None]:
    """Summarise a report's ``metrics.json``: (beta, coverage) of the new paths.

    Weighted by the replace region's area times the number of layers that print each distinct layer;
    (None, None) without metrics.
    """
    num_b = num_c = den = 0.0
    for layer in metrics.get("layers", []):
        new = layer.get("new") or {}
        beta, cov = new.get("beta"), new.get("coverage")
        if beta is None or cov is None or beta != beta or cov != cov:  # missing or NaN
            continue
        w = float(layer.get("region_area_mm2", 0.0)) * max(1, len(layer.get("layers", [])))
        num_b, num_c, den = num_b + w * beta, num_c + w * cov, den + w
    return (num_b / den, num_c / den) if den > 0 else (None, None)


def process(task: Task) -> FileResult:
    """Run one task; never raises for a loadpath failure (the result says it)."""
    import json

    from loadpath.plugin.job import JobRequest, run_job

    t0 = time.perf_counter()
    tmp_report = None
    report = task.report
    if report is None and task.metrics:
        tmp_report = Path(tempfile.mkdtemp(prefix="loadpath-batch-report-"))
        report = tmp_report
    try:
        req = JobRequest(
            input=task.input,
            loadcase=task.loadcase,
            output=task.output,
            report=report,
            cli=dict(task.cli),
            slicer_settings=task.slicer_settings,
            force=task.force,
        )
        res = run_job(req)
        beta = cov = None
        if res.report is not None and (Path(res.report).parent / "metrics.json").is_file():
            beta, cov = metrics_summary(
                json.loads((Path(res.report).parent / "metrics.json").read_text("utf-8"))
            )
        status = "kept" if res.error else "ok" if res.changed else "unchanged"
        message = res.error or (res.warnings[0] if res.warnings else "")
        return FileResult(
            str(task.input),
            status,
            time.perf_counter() - t0,
            beta,
            cov,
            str(res.output) if res.written else None,
            message,
            res.verdict.line().split(": ", 1)[-1] if res.verdict is not None else "",
            list(res.warnings),
        )
    except LoadpathError as exc:
        return FileResult(str(task.input), "failed", time.perf_counter() - t0, message=str(exc))
    except Exception as exc:  # a bug in one file must not stop the others
        return FileResult(
            str(task.input),
            "failed",
            time.perf_counter() - t0,
            message=f"internal error ({type(exc).__name__}: {exc}); please report this",
        )
    finally:
        if tmp_report is not None:
            shutil.rmtree(tmp_report, ignore_errors=True)


# ---------------------------------------------------------------------------------------------- many files


Progress = Callable[[FileResult, int, int], None]


def run_local(
    tasks: Sequence[Task], workers: int | None = None, progress: Progress | None = None
) -> list[FileResult]:
    """Process the tasks in ``workers`` processes (default one per core); results in task order."""
    from loadpath.pipeline.paths import default_workers

    n = len(tasks)
    workers = max(1, min(workers or os.cpu_count() or default_workers(), n))
    results: list[FileResult | None] = [None] * n
    if workers == 1:
        for i, t in enumerate(tasks):
            res = process(t)
            results[i] = res
            if res.output:
                note_written(res.output)
            if progress:
                progress(res, i + 1, n)
        return [r for r in results if r is not None]
    import multiprocessing

    from loadpath.procs import stop_pool, warm_start_method, worker_init

    ctx = multiprocessing.get_context(warm_start_method())

    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=worker_init,
                               initargs=(None, True))
    before = [_stamp(t.output) for t in tasks]
    try:
        futures = {pool.submit(process, t): i for i, t in enumerate(tasks)}
        for done, fut in enumerate(as_completed(futures), 1):
            i = futures[fut]
            try:
                res = fut.result()
            except Exception as exc:  # the worker process died (out of memory, killed)
                res = FileResult(
                    str(tasks[i].input),
                    "failed",
                    0.0,
                    message=f"the worker process stopped ({type(exc).__name__}: {exc})",
                )
            results[i] = res
            if res.output:
                note_written(res.output)
            if progress:
                progress(res, done, n)
        pool.shutdown(wait=True)  # inside: a signal during the wait stops the pool too
    except BaseException:  # Ctrl-C, SIGTERM: end the workers (they remove their temp files) and say so
        stop_pool(pool)
        # a worker may have renamed its output into place before its result reached this process:
        # the atomic write gives a finished file a new inode, so a changed stamp is a file written
        for i, t in enumerate(tasks):
            if results[i] is None and _stamp(t.output) not in (None, before[i]):
                note_written(t.output)
        raise
    return [r for r in results if r is not None]


def _stamp(path: Path) -> tuple[int, int] | None:
    """``(inode, mtime in ns)`` of ``path``, or None when it does not exist."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns


# ---------------------------------------------------------------------------------------------- output


def _num(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def table(results: Iterable[FileResult]) -> str:
    """Format the summary: one row per file, then the totals, the failures and every warning.

    Columns: file, status, time, beta, coverage, warnings (count), verdict (what was replaced and
    gained, :mod:`loadpath.verdict`).
    """
    rows = list(results)
    width = max([len("file")] + [len(r.file) for r in rows])
    lines = [
        f"{'file':<{width}}  {'status':<9}  {'time s':>7}  {'beta':>6}  {'coverage':>8}  {'warn':>4}  verdict"
    ]
    for r in rows:
        lines.append(
            f"{r.file:<{width}}  {r.status:<9}  {r.seconds:7.1f}  {_num(r.beta, '6.3f'):>6}  "
            f"{_num(r.coverage, '8.3f'):>8}  {len(r.warnings):>4}  {r.verdict or '-'}"
        )
    failed = [r for r in rows if r.failed]
    lines.append(
        f"{len(rows)} file(s): {sum(r.status == 'ok' for r in rows)} ok, "
        f"{sum(r.status == 'unchanged' for r in rows)} unchanged, {sum(r.status == 'kept' for r in rows)} "
        f"kept, {len(failed)} failed"
    )
    for r in failed:
        lines.append(f"{r.file}: {r.message}")
    for r in rows:  # every warning, not only the first (a kept failure is one of them)
        lines.extend(f"{r.file}: warning: {' '.join(w.split())}" for w in r.warnings)
    return "\n".join(lines)


class BatchProgress:
    """``[#####.....] 3/10 files, 1 failed, 12 s`` on a terminal (stderr); silent otherwise."""

    def __init__(self, stream: Any = None) -> None:
        self.stream = stream or sys.stderr
        self.on = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()
        self.failed = 0
        self.width = 0

    def __call__(self, result: FileResult, done: int, total: int) -> None:
        """Count ``result`` and redraw the bar (``done`` of ``total`` files finished)."""
        self.failed += result.failed
        if not self.on:
            return
        bar = int(24 * done / total) if total else 24
        line = (
            f"\rloadpath batch: [{'#' * bar}{'.' * (24 - bar)}] {done}/{total} files, {self.failed} failed, "
            f"{time.perf_counter() - self.t0:.0f} s"
        )
        self.width = max(self.width, len(line))
        self.stream.write(line)
        self.stream.flush()

    def close(self) -> None:
        """Clear the bar's line."""
        if self.on and self.width:
            self.stream.write("\r" + " " * self.width + "\r")
            self.stream.flush()
