"""Run the whole pipeline on the shipped example and write the result and a report to ./loadpath-demo/.

The example is the open-hole tensile specimen of ASTM D5766, sliced by PrusaSlicer 2.5 for an
Original Prusa i3 MK3S; the demo writes ohs.loadpath.gcode, report/index.html and
report/metrics.json.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from loadpath import engines

HELP = "run the pipeline on the shipped example into ./loadpath-demo/"

__all__ = ["HELP", "add_args", "run", "example_files"]


def add_args(parser: argparse.ArgumentParser) -> None:
    """Options: where to write, and the engine."""
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("loadpath-demo"),
        metavar="DIR",
        help="output folder (default ./loadpath-demo)",
    )
    parser.add_argument(
        "--engine",
        choices=engines.NAMES,
        default=None,
        help="path engine (default: the load case's, else the level sets and the swarm where they give way)",
    )
    parser.add_argument("--no-report", action="store_true", help="skip the HTML report")


def example_files() -> tuple[Path, Path]:
    """Return the shipped example's G-code and load case."""
    from importlib import resources

    root = resources.files("loadpath.examples")
    return Path(str(root / "ohs.gcode")), Path(str(root / "ohs.toml"))


def run(args: argparse.Namespace) -> int:
    """Run the demo."""
    from loadpath.plugin.commands.run import execute
    from loadpath.plugin.job import JobRequest

    gcode_path, case = example_files()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    cli = {"engine": args.engine} if args.engine else {}
    req = JobRequest(
        input=gcode_path,
        loadcase=case,
        output=out / "ohs.loadpath.gcode",
        report=None if args.no_report else out / "report",
        cli=cli,
    )
    result = execute(req)
    t = result.times
    total = sum(v for k, v in t.items())
    print(f"loadpath demo: {gcode_path.name} + {case.name} -> {result.output}")
    if result.report:
        print(f"  report: {result.report}")
    stages = ", ".join(f"{k} {v:.2f} s" for k, v in t.items())
    print(f"  {stages} (total {total:.2f} s)")
    if result.pipeline is not None and result.pipeline.splice is not None:
        blocks = result.pipeline.splice.blocks
        # the engines that laid them (the level sets, the swarm where they gave way), as the verdict
        engine = result.verdict.engine if result.verdict is not None else result.settings.engine
        print(
            f"  replaced {len(blocks)} infill blocks in layers "
            f"{', '.join(str(b.layer + 1) for b in blocks)} with {engine} paths"
        )
    sys.stdout.flush()
    return 0
