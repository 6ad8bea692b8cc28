"""Reprocess many G-code files with one load case, in parallel.

Inputs are folders (their .gcode/.bgcode files), files or quoted glob patterns; earlier outputs
(*.loadpath.gcode) are skipped.  Outputs are named like `loadpath run` without -o (IN.loadpath.gcode
next to each input) or keep the input's name inside --out DIR.  A progress bar is shown on a
terminal and a summary table (file, status, time, beta, coverage, warnings, verdict) is printed at
the end, then every file's warnings.  One
failing file does not stop the others; the exit status is 1 when any file failed, else 0.  With
--cluster tcp://host:8786 the files are processed on a Dask cluster (its workers need loadpath
installed, not the files).
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "reprocess many G-code files in parallel (or on a Dask cluster)"

__all__ = ["HELP", "add_args", "run"]


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the inputs, the load case, parallelism, then the settings schema's flags (as `loadpath run`)."""
    from loadpath.plugin import settings

    parser.add_argument(
        "inputs", nargs="+", metavar="DIR_OR_GLOB", help="folders, files or quoted glob patterns"
    )
    parser.add_argument("--loadcase", required=True, type=Path, metavar="CASE.toml", help="the load case")
    parser.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        default=None,
        help="write the outputs into DIR under the inputs' names (default: IN.loadpath.gcode "
        "next to each input)",
    )
    parser.add_argument(
        "--report", type=Path, metavar="DIR", default=None, help="keep each file's HTML report in DIR/<name>/"
    )
    parser.add_argument(
        "--no-metrics",
        dest="metrics",
        action="store_false",
        help="skip beta and coverage (about a second per distinct layer)",
    )
    parser.add_argument(
        "--cluster",
        metavar="tcp://HOST:8786",
        default=None,
        help="process on the Dask cluster with this scheduler (pip install 'loadpath[cluster]')",
    )
    from loadpath.plugin.commands.run import add_force

    add_force(parser)
    settings.add_cli_options(parser)
    # --jobs here is the number of files at once; each file's engine workers stay at 1 (--set jobs=N)
    parser.add_argument(
        "--jobs",
        dest="files_at_once",
        type=int,
        default=0,
        metavar="N",
        help="files processed at once (default: one per core)",
    )


def run(args: argparse.Namespace) -> int:
    """Run the command (see the module docstring)."""
    import sys

    from loadpath.plugin import batch, settings

    if args.files_at_once < 0:
        from loadpath.errors import SettingsError

        raise SettingsError(f"--jobs {args.files_at_once}: give a number of files >= 1 (0: one per core)")
    cli = settings.cli_values(args)
    settings.Settings().with_values(cli, "command line")  # a mistyped --set key: one error, not one a file
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    tasks = batch.plan(
        args.inputs,
        args.loadcase,
        args.out,
        cli,
        args.report,
        args.metrics,
        Path(args.slicer_settings) if args.slicer_settings else None,
        args.force,
    )
    bar = batch.BatchProgress()
    try:
        if args.cluster:
            from loadpath.plugin.batch_cluster import run_cluster

            results = run_cluster(tasks, args.cluster, progress=bar)
        else:
            results = batch.run_local(tasks, args.files_at_once or None, progress=bar)
    finally:
        bar.close()
    print(batch.table(results), file=sys.stdout)
    return 1 if any(r.failed for r in results) else 0
