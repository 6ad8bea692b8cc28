"""Reprocess one G-code file: replace the chosen infill with stress-aligned paths.

Without -o the result goes next to the input as IN.loadpath.gcode; --in-place rewrites the input
atomically.  On any failure the exit status is non-zero, one line on stderr says what is wrong, how
to fix it and what became of the files, and the input is untouched; with --on-failure keep the
slicer's G-code is kept, a warning says what was kept and the exit status is 0.  Every run ends
with one verdict line on stderr (what was replaced, the predicted stiffness change, print time,
mass, warnings), which also goes into the G-code's header and $XDG_STATE_HOME/loadpath/runs.log.
A file loadpath already processed is refused unless --force.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HELP = "reprocess one G-code file with stress-aligned infill"

__all__ = ["HELP", "add_args", "add_force", "run", "Progress", "execute"]


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the options of interface.md, then the settings schema's own flags."""
    from loadpath.plugin import settings

    parser.add_argument(
        "input", metavar="IN.gcode", type=Path, help="G-code from PrusaSlicer or Cura (.gcode or .bgcode)"
    )
    parser.add_argument("--loadcase", required=True, type=Path, metavar="CASE.toml", help="the load case")
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        metavar="OUT.gcode",
        default=None,
        help="where to write the result (default: IN.loadpath.gcode next to the input)",
    )
    parser.add_argument(
        "--report",
        type=Path,
        metavar="DIR",
        default=None,
        help="write an HTML report and metrics.json into DIR",
    )
    parser.add_argument("--in-place", action="store_true", help="rewrite the input file itself (atomically)")
    add_force(parser)
    settings.add_cli_options(parser)


def add_force(parser: argparse.ArgumentParser) -> None:
    """``--force``: process a file loadpath already wrote (refused otherwise)."""
    parser.add_argument(
        "--force",
        action="store_true",
        help="process a file loadpath already processed (its header says so; refused otherwise)",
    )


class Progress:
    """A one-line progress bar on a terminal (stderr); silent otherwise."""

    LABELS = {
        "geometry": "layer regions",
        "fea": "stress analysis",
        "paths": "paths",
        "splice": "writing G-code",
        "judge": "predicting",
    }

    def __init__(self, stream=None) -> None:
        self.stream = stream or sys.stderr
        self.on = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()
        self.last = ""
        self.layout = 0

    def __call__(self, stage: str, done: int, total: int) -> None:
        """Show ``done`` of ``total`` for a stage.

        The stage ``"layout"`` (:func:`loadpath.plugin.job.run_job`) draws nothing: ``done`` numbers
        the layout the run lays from now on, and from the second one the bar names it, so a run that
        lays and judges several (``density = "auto"``, the solid layouts) does not seem to start over.
        """
        if stage == "layout":
            self.layout = done
            return
        if not self.on:
            return
        width = 24
        fill = int(width * done / total) if total else width
        label = self.LABELS.get(stage, stage)
        if self.layout > 1:
            label = f"layout {self.layout}: {label}"
        line = (
            f"\rloadpath: {label:<16} [{'#' * fill}{'.' * (width - fill)}] "
            f"{done}/{total}  {time.perf_counter() - self.t0:5.1f} s"
        )
        if line != self.last:
            self.stream.write(line + " " * max(0, len(self.last) - len(line)))  # no tail of a longer one
            self.stream.flush()
            self.last = line

    def close(self) -> None:
        """Clear the bar."""
        if self.on and self.last:
            self.stream.write("\r" + " " * len(self.last) + "\r")
            self.stream.flush()


def execute(request, quiet: bool = False):
    """Run a job with a progress bar and print its warnings; returns the JobResult (raises on failure)."""
    from loadpath.plugin.job import run_job

    bar = Progress()
    try:
        result = run_job(request, progress=None if quiet else bar)
    finally:
        bar.close()
    for w in result.warnings:
        print(f"loadpath: warning: {w}", file=sys.stderr)
    if result.error is None and result.written and sys.stderr.isatty():  # the verdict ends the run
        print(
            f"loadpath: wrote {result.output}" + (f"; report {result.report}" if result.report else ""),
            file=sys.stderr,
        )
    if result.verdict is not None:  # on a terminal or not: hooks, logs and scripts see it too
        print(result.verdict.line(), file=sys.stderr)
    return result


def run(args: argparse.Namespace) -> int:
    """Run the command (see the module docstring)."""
    from loadpath.errors import SettingsError
    from loadpath.plugin import settings
    from loadpath.plugin.job import JobRequest

    if args.in_place and args.output is not None:
        raise SettingsError("give either -o OUT or --in-place, not both")
    cli = settings.cli_values(args)
    req = JobRequest(
        input=args.input,
        loadcase=args.loadcase,
        output=args.output,
        in_place=args.in_place,
        report=args.report,
        cli=cli,
        slicer_settings=Path(args.slicer_settings) if args.slicer_settings else None,
        force=args.force,
    )
    execute(req)
    return 0
