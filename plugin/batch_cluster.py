"""``loadpath batch --cluster``: the same files processed on a Dask cluster.

The workers need loadpath installed but not the files: each task carries the file's bytes and the
load case's text, runs :func:`loadpath.plugin.batch.process` in a temporary folder on the worker
and returns the output's bytes, which are written here, atomically.  Dask is optional
(``pip install 'loadpath[cluster]'``).
"""

from __future__ import annotations

import shutil
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from loadpath.errors import LoadpathError, SettingsError
from loadpath.plugin.batch import FileResult, Progress, Task, process

__all__ = ["process_remote", "run_cluster"]


def process_remote(
    name: str, data: bytes, loadcase_text: str, cli: Mapping[str, Any], metrics: bool = True
) -> tuple[FileResult, bytes | None]:
    """One file on a cluster worker: its bytes in, the output's bytes out (no shared file system)."""
    work = Path(tempfile.mkdtemp(prefix="loadpath-batch-"))
    try:
        inp = work / Path(name).name
        inp.write_bytes(data)
        case = work / "case.toml"
        case.write_text(loadcase_text, encoding="utf-8")
        out = work / ("out" + inp.suffix)
        res = process(
            Task(inp, out, case, {**cli, "jobs": 1}, None, metrics)
        )  # dask workers: no child processes
        blob = out.read_bytes() if res.output and out.is_file() else None
        return replace(res, file=name, output=None), blob
    finally:
        shutil.rmtree(work, ignore_errors=True)


def run_cluster(
    tasks: Sequence[Task], address: str, progress: Progress | None = None, timeout: float = 30.0
) -> list[FileResult]:
    """Process the tasks on the Dask cluster whose scheduler is at ``address``; outputs written here.

    Raises
    ------
    SettingsError
        Dask is not installed, or the scheduler cannot be reached.
    """
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise SettingsError("--cluster needs Dask: pip install 'loadpath[cluster]'") from None
    from loadpath.plugin.job import write_atomic

    try:
        client = Client(address, timeout=timeout)
    except OSError as exc:
        raise SettingsError(
            f"cannot reach the Dask scheduler at {address!r} ({exc}); check the address "
            "(tcp://host:8786) and that the scheduler is running"
        ) from None
    n = len(tasks)
    results: list[FileResult | None] = [None] * n
    try:
        futures = {}
        for i, t in enumerate(tasks):
            fut = client.submit(
                process_remote,
                str(t.input),
                t.input.read_bytes(),
                Path(t.loadcase).read_text(encoding="utf-8"),
                dict(t.cli),
                t.metrics,
                pure=False,
                key=f"loadpath-{i}-{t.input.name}-{time.time_ns()}",
            )
            futures[fut] = i
        for done, fut in enumerate(dask_completed(list(futures)), 1):
            i = futures[fut]
            try:
                res, blob = fut.result()
                if blob is not None:
                    write_atomic(tasks[i].output, blob, mode_like=tasks[i].input)
                    res = replace(res, output=str(tasks[i].output))
            except LoadpathError as exc:
                res = FileResult(str(tasks[i].input), "failed", 0.0, message=str(exc))
            except Exception as exc:  # a worker lost, loadpath missing on a worker, ...
                res = FileResult(
                    str(tasks[i].input), "failed", 0.0, message=f"on the cluster: {type(exc).__name__}: {exc}"
                )
            results[i] = res
            if progress:
                progress(res, done, n)
    finally:
        client.close()
    return [r for r in results if r is not None]
