"""The ``loadpath`` command line: ``main(argv) -> exit status``.

Subcommands live in :mod:`loadpath.plugin.commands` (one module each).  Any :class:`LoadpathError`
becomes one line on stderr, ``loadpath: <what is wrong and how to fix it>``, and exit status 1.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from loadpath import __version__
from loadpath.errors import LoadpathError

__all__ = ["main", "COMMANDS"]

COMMANDS = {
    "run": "loadpath.plugin.commands.run",
    "demo": "loadpath.plugin.commands.demo",
    "inspect": "loadpath.plugin.commands.inspect",
    "compare": "loadpath.plugin.commands.compare",
    "batch": "loadpath.plugin.commands.batch",
    "serve": "loadpath.plugin.commands.serve",
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
        Exit status: 0 on success, 1 on a loadpath error, 2 on a usage error, 130 on interrupt.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(command if command in COMMANDS else None)
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except LoadpathError as exc:
        print(f"loadpath: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("loadpath: interrupted; no file was written", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
