"""Stage budgets against real parts: the largest size each budget of ``loadpath.budget`` meets.

Usage::

    python benchmarks/bench_budget.py [OUT_DIR] [--run] [--files F.gcode ...]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

Every committed real slicer file (``tests/data/**``, ``examples/ohs.gcode``) goes through
``loadpath inspect`` (geometry: segments per layer, samples of the nearest-lines split) and, with
``--run``, through ``loadpath run`` with a side pull (:data:`SIDES`) (``--replace
solid,sparse``: mesh estimate and gmsh's node count, engine pitch cells).  Each budget check is
recorded (``loadpath.budget.check`` wrapped, nothing else changed), and the table prints, per
budget, the largest value any real file reached, which file, and the ratio budget / largest: the
margin before a real part would be refused.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from cases import side_case  # noqa: E402

SIDES = side_case((500.0, 0.0, 0.0), held_within=5.0, loaded_within=5.0)
"""A load case any part takes: clamped at its smallest x, pulled at its largest."""

_NAMES = {
    "extrusion segments": "LAYER_SEGMENTS",
    "samples of the nearest-lines split": "SPLIT_SAMPLES",
    "triangles estimated": "MESH_ELEMENTS",
    "mesh nodes from gmsh": "MESH_NODES",
    "tetrahedra of the layered mesh": "MESH_ELEMENTS (3D)",
    "pitch cells for the path engine": "ENGINE_CELLS",
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", nargs="?", type=Path, default=None)
    ap.add_argument("--run", action="store_true", help="also run each file (mesh and engine budgets)")
    ap.add_argument("--files", nargs="*", type=Path, default=None)
    args, _ = ap.parse_known_args(argv)

    from loadpath import budget
    from loadpath.plugin.cli import main as cli

    seen: dict[str, tuple[float, str]] = {}
    current = [""]
    real_check = budget.check

    def recording(value, limit, where, what, fix):
        key = next((v for k, v in _NAMES.items() if what.startswith(k)), what)
        if value > seen.get(key, (-1.0, ""))[0]:
            seen[key] = (float(value), current[0])
        return real_check(value, limit, where, what, fix)

    budget.check = recording
    files = args.files or sorted((REPO / "tests" / "data").rglob("*.gcode")) + [REPO / "examples" / "ohs.gcode"]
    try:
        _measure(files, args.run, SIDES, cli, current)
    except KeyboardInterrupt:  # the table of what was measured so far
        print("(stopped)")
    budget.check = real_check
    _table(budget, seen)
    return 0


def _measure(files, run: bool, loadcase: str, cli, current) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        case = Path(tmp) / "case.toml"
        case.write_text(loadcase)
        for f in files:
            current[0] = f.name
            commands = [["inspect", str(f)]]
            if run:
                commands.append(["run", str(f), "--loadcase", str(case), "-o", str(Path(tmp) / "out.gcode"),
                                 "--replace", "solid,sparse", "--no-cache", "--set", "jobs=1"])
            for cmd in commands:
                t0 = time.perf_counter()
                err = io.StringIO()
                with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                    code = cli(cmd)
                last = (err.getvalue().strip().splitlines() or [""])[-1][:90]
                print(f"{cmd[0]:<8} {f.name:<52} exit {code}  {time.perf_counter() - t0:6.1f} s  {last}",
                      flush=True)


def _table(budget, seen) -> None:
    limits = {"LAYER_SEGMENTS": budget.LAYER_SEGMENTS, "SPLIT_SAMPLES": budget.SPLIT_SAMPLES,
              "MESH_ELEMENTS": budget.MESH_ELEMENTS, "MESH_ELEMENTS (3D)": budget.MESH_ELEMENTS,
              "MESH_NODES": budget.MESH_NODES, "ENGINE_CELLS": budget.ENGINE_CELLS}
    print()
    print(f"{'budget':<20} {'limit':>12} {'largest real':>14} {'margin':>8}  file")
    for key, limit in limits.items():
        value, where = seen.get(key, (0.0, "(not reached by these files)"))
        margin = f"{limit / value:7.0f}x" if value else "     -"
        print(f"{key:<20} {limit:>12,} {value:>14,.0f} {margin}  {where}")


if __name__ == "__main__":
    sys.exit(main())
