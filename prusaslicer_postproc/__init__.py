"""PrusaSlicer post-processing entry point ``loadpath-prusaslicer`` (slicer-conventions.md §1).

Put this line into Print Settings > Output options > Post-processing scripts (absolute paths)::

    /path/to/venv/bin/loadpath-prusaslicer --loadcase /path/to/case.toml [options of loadpath run]

PrusaSlicer (and its descendants SuperSlicer, OrcaSlicer, Bambu Studio, which share the hook) runs
the line through a shell and appends the G-code path as the **last** argument.  The file is
rewritten in place, atomically, in its own format (binary G-code stays binary).  The slicer's
configuration is read from the ``SLIC3R_*`` environment the hook exports (any case) and from the
file's configuration block, whichever is present (the environment wins).

On failure the exit status is 1 and one line on stderr says what went wrong and how to fix it
(PrusaSlicer shows it in its error dialog); the G-code file is untouched.  With ``--on-failure
keep`` the slicer's G-code is kept, a warning is printed and the exit status is 0.  Relative
paths (``--loadcase``) are resolved against PrusaSlicer's working directory, which the user does
not control: give absolute paths.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main", "build_parser"]

PROG = "loadpath-prusaslicer"


def build_parser() -> argparse.ArgumentParser:
    """Build the parser: the options of ``loadpath run`` that make sense in place (no ``-o``)."""
    from loadpath.plugin import settings

    parser = argparse.ArgumentParser(
        prog=PROG,
        description="PrusaSlicer post-processing script: replaces infill with stress-aligned paths, in "
        "place. PrusaSlicer appends the G-code path as the last argument.",
    )
    parser.add_argument(
        "--loadcase",
        required=True,
        type=Path,
        metavar="CASE.toml",
        help="the load case (an absolute path: the slicer's working directory is not yours)",
    )
    parser.add_argument(
        "--report",
        type=Path,
        metavar="DIR",
        default=None,
        help="write an HTML report and metrics.json into DIR",
    )
    from loadpath.plugin.commands.run import add_force

    add_force(parser)
    settings.add_cli_options(parser)
    return parser


def _fail(message: str, status: int = 1) -> int:
    sys.stderr.write(f"{PROG}: {' '.join(message.split())}\n")
    return status


def main(argv: Sequence[str] | None = None, env: dict[str, str] | None = None) -> int:
    """Run the hook.

    Parameters
    ----------
    argv : sequence of str, optional
        The options, then the G-code path last; default ``sys.argv[1:]``.
    env : mapping, optional
        Environment to read ``SLIC3R_*`` from; default ``os.environ``.

    Returns
    -------
    int
        0 on success (or a failure kept with ``--on-failure keep``), 1 on a failure, 2 on a usage error.
    """
    args_in = list(sys.argv[1:] if argv is None else argv)
    if any(a in ("-h", "--help") for a in args_in):
        build_parser().print_help()
        return 0
    if not args_in or args_in[-1].startswith("-"):
        return _fail(
            "no G-code path: PrusaSlicer appends it as the last argument; put "
            f"'{PROG} --loadcase /path/to/case.toml' in Print Settings > Output options > "
            "Post-processing scripts",
            2,
        )
    gcode_path = Path(args_in[-1])
    try:
        args = build_parser().parse_args(args_in[:-1])
    except SystemExit as exc:  # argparse printed its usage message
        return int(exc.code or 0)

    from loadpath.errors import LoadpathError
    from loadpath.plugin import lifecycle, settings
    from loadpath.plugin.job import JobRequest, run_job

    written: list = []

    try:
        request = JobRequest(
            input=gcode_path,
            loadcase=args.loadcase,
            in_place=True,
            report=args.report,
            cli=settings.cli_values(args),
            env=dict(os.environ if env is None else env),
            slicer_settings=Path(args.slicer_settings) if args.slicer_settings else None,
            force=args.force,
        )
        with lifecycle.terminate_as_interrupt(), lifecycle.record_writes(written):
            result = run_job(request)
    except LoadpathError as exc:
        return _fail(str(exc))  # run_job says what became of the file
    except KeyboardInterrupt as exc:  # SIGINT or SIGTERM (lifecycle.Interrupted)
        how = getattr(exc, "signame", "interrupted")
        return _fail(f"{how}: stopped; " + ("the G-code was left unchanged" if not written
                                            else lifecycle.what_was_written(written)),
                     getattr(exc, "status", 130))
    except Exception as exc:  # a bug or a resource: one line, the export's file as it was written
        if os.environ.get("LOADPATH_DEBUG", "") not in ("", "0"):
            raise
        return _fail(f"internal error ({type(exc).__name__}: {' '.join(str(exc).split())[:200]}); the G-code "
                     "was left unchanged; please report this with the G-code and load case")
    for warning in result.warnings:
        sys.stderr.write(f"{PROG}: warning: {' '.join(warning.split())}\n")
    if result.verdict is not None:  # PrusaSlicer shows stderr only on failure: the log has it too
        sys.stderr.write(result.verdict.line() + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
