"""The ``loadpath`` command line: ``main(argv) -> exit status``.

Subcommands live in :mod:`loadpath.plugin.commands` (one module each).  Any :class:`LoadpathError`
becomes one line on stderr, ``loadpath: <what is wrong and how to fix it>``, and exit status 1; any
other exception (MemoryError, RecursionError, a numpy error, a bug) one line with its type and the
advice to report it (``LOADPATH_DEBUG=1`` re-raises it with its traceback).  SIGINT and SIGTERM stop
the command the same way: temporary files are removed and one line says which files were written.
Python and numpy warnings are not shown (``LOADPATH_DEBUG=1`` shows them).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from collections.abc import Sequence

from loadpath import __version__
from loadpath.errors import LoadpathError, showing_tracebacks
from loadpath.plugin import lifecycle

__all__ = ["main", "COMMANDS"]

COMMANDS = {
    "run": "loadpath.plugin.commands.run",
    "demo": "loadpath.plugin.commands.demo",
    "inspect": "loadpath.plugin.commands.inspect",
    "compare": "loadpath.plugin.commands.compare",
    "batch": "loadpath.plugin.commands.batch",
    "serve": "loadpath.plugin.commands.serve",
    "edit": "loadpath.plugin.commands.edit",
    "profile": "loadpath.plugin.commands.profile",
}


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """Build the argument parser with every available subcommand (``only``: that one alone).

    Each subcommand's module is imported to add its options; ``loadpath run`` builds only its own,
    so a run does not import the service's HTTP server or the report's modules at start-up.
    """
    parser = argparse.ArgumentParser(
        prog="loadpath", description="Stress-aligned infill for PrusaSlicer and Cura G-code."
    )
    parser.add_argument("--version", action="version", version=f"loadpath {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module_name in COMMANDS.items():
        if only is not None and name != only:
            continue
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name == module_name:
                continue  # not built yet in this checkout
            raise
        p = sub.add_parser(name, help=module.HELP, description=module.__doc__)
        module.add_args(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status: 0 on success, 1 on a loadpath error, 2 on a usage error, 130 on SIGINT (Ctrl-C),
        143 on SIGTERM.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    from loadpath.memory import map_large_arrays

    map_large_arrays()  # the resident size follows what a large file's arrays hold (loadpath.memory)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(command if command in COMMANDS else None)
    args = parser.parse_args(argv)
    debug = showing_tracebacks()
    # quiet only for the command's duration: a caller in the same process (tests, a plugin) keeps
    # its own warning filters and hooks afterwards
    hook, options = sys.unraisablehook, list(sys.warnoptions)
    try:
        with warnings.catch_warnings():
            if not debug:  # Python and numpy warnings are for developers; users get loadpath's lines
                warnings.simplefilter("ignore")
                if "ignore" not in sys.warnoptions:  # passed on as -Wignore to multiprocessing's
                    sys.warnoptions.append("ignore")  # helper processes (resource tracker, forkserver)
                # nor "Exception ignored in ..." tracebacks: a Ctrl-C during a fork raises inside an
                # at-fork hook, where Python drops it (lifecycle remembers the signal; stages re-raise)
                sys.unraisablehook = _drop_unraisable
            return _main(args, argv, debug)
    finally:
        sys.unraisablehook = hook
        sys.warnoptions[:] = options


def _main(args: argparse.Namespace, argv: Sequence[str] | None, debug: bool) -> int:
    written: list = []
    with lifecycle.terminate_as_interrupt(), lifecycle.record_writes(written):
        try:
            status = int(args._run(args) or 0)
            if status == 0:  # a signal whose exception Python dropped (inside a fork)
                lifecycle.raise_if_stopped()
            return status
        except LoadpathError as exc:
            _say(f"loadpath: {exc}")
            return 1
        except lifecycle.Interrupted as exc:
            _say(f"loadpath: {exc.signame}: stopped; {lifecycle.what_was_written(written)}")
            if argv is None:  # the real command: end now, without the interpreter's exit hooks, which
                _flush_and_exit(exc.status)  # would join stopped pools and print their threads' errors
            return exc.status
        except BrokenPipeError:
            _quiet_stdout()
            _say("loadpath: the output pipe was closed before everything was printed (BrokenPipeError); "
                 f"{lifecycle.what_was_written(written)}")
            return 1
        except Exception as exc:  # a bug or a resource: one line, never a traceback (LOADPATH_DEBUG=1 keeps it)
            if debug:
                raise
            _say(f"loadpath: {_internal(exc)}; {lifecycle.what_was_written(written)}")
            return 1


def _internal(exc: BaseException) -> str:
    """One line for an unexpected exception: its type, what it says, and what to do."""
    if isinstance(exc, MemoryError):
        return f"out of memory ({type(exc).__name__}); close other programs or process a smaller file"
    if isinstance(exc, RecursionError):
        return "input nested too deeply to read (RecursionError); please report this with the input files"
    text = " ".join(str(exc).split())[:200]
    return (f"internal error ({type(exc).__module__}.{type(exc).__name__}: {text}); please report this with "
            "the input files (LOADPATH_DEBUG=1 shows where)")


def _drop_unraisable(unraisable: object) -> None:
    """``sys.unraisablehook`` outside LOADPATH_DEBUG: say nothing."""


def _flush_and_exit(status: int) -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(status)


def _say(line: str) -> None:
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _quiet_stdout() -> None:
    """After a broken pipe: point stdout at /dev/null so the interpreter's final flush stays silent."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
