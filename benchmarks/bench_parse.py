#!/usr/bin/env python3
"""Parse speed of loadpath.gcode: lines per second of the whole structured-array pass, one core.

For each real file: the median wall time of ``loadpath.gcode.parse(data)`` over repeated runs (text
bytes in memory -> Program with per-line state, MOVE_DTYPE moves, layers, blocks), and, measured in
the same run as a reference, a minimal pure-Python pass over the same text (split lines, strip the
comment, split the words: less than any real per-line parser does).  Target: >= 1 000 000 lines/s.

Files: the shipped example (PrusaSlicer 2.5), the specimen sliced by CuraEngine 4.13 (when
installed), the 120-layer tower sliced by PrusaSlicer 2.5, a real PrusaSlicer 2.9.2 file with arcs
(tests/data/current), and large files made by repeating the layers of a real file between its own
header and trailer (every line a real line).

Usage::

    .venv/bin/python benchmarks/bench_parse.py [--repeat 7] [--big-lines 1000000]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"  # one core: before numpy is imported

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

from loadpath import gcode  # noqa: E402

TARGET = 1_000_000


def median_time(fn, repeat: int) -> tuple[float, float]:
    """Median CPU time of this process (one core: the figure the target is about) and median wall time."""
    cpu, wall = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        fn()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - t)
    return statistics.median(cpu), statistics.median(wall)


def python_reference(data: bytes) -> int:
    n = 0
    for line in data.decode("utf-8").splitlines():
        code = line.split(";", 1)[0].split()
        n += len(code)
    return n


def repeat_layers(data: bytes, target_lines: int) -> bytes:
    """Header + the file's layers repeated until ``target_lines`` + trailer: real lines only."""
    p = gcode.parse(data)
    head = p.lines_bytes(0, p.layers[0].start)
    body = p.lines_bytes(p.layers[0].start, p.print_end)
    tail = p.lines_bytes(p.print_end, p.n_lines)
    body_lines = p.print_end - p.layers[0].start
    k = max(1, round((target_lines - p.n_lines + body_lines) / body_lines))
    return head + body * k + tail


def files(big_lines: int) -> list[tuple[str, bytes]]:
    out = [("PrusaSlicer 2.5 specimen (examples/ohs.gcode)", (REPO / "examples" / "ohs.gcode").read_bytes())]
    cur = REPO / "tests" / "data" / "current" / "prusaslicer-2.9.2-calicat-mini-arcs-m486.gcode"
    out.append(("PrusaSlicer 2.9.2 calicat, arcs (trimmed)", cur.read_bytes()))
    tmp = Path(tempfile.mkdtemp(prefix="bench_parse_"))
    try:
        import slicing

        stl = slicing.write_stl(slicing.ohs_mesh(), tmp / "ohs.stl")
        cura = slicing.slice_cura(stl, tmp / "ohs_cura.gcode", **slicing.CURA_MIXED).read_bytes()
        out.append(("CuraEngine 4.13 specimen", cura))
        tower = slicing.write_stl(slicing.tower_mesh(), tmp / "tower.stl")
        tower_g = slicing.slice_prusa(tower, tmp / "tower.gcode", **slicing.PRUSA_MIXED).read_bytes()
        out.append(("PrusaSlicer 2.5 tower, 120 layers", tower_g))
        out.append(
            (
                f"PrusaSlicer tower layers repeated (~{big_lines / 1e6:.1f} M lines)",
                repeat_layers(tower_g, big_lines),
            )
        )
        out.append(
            (
                f"Cura specimen layers repeated (~{big_lines / 1e6:.1f} M lines)",
                repeat_layers(cura, big_lines),
            )
        )
    except Exception as exc:  # slicers missing: report what can be measured
        print(f"(real slicers unavailable, {exc}; using the shipped example only for the large file)")
        out.append(
            (
                f"PrusaSlicer specimen layers repeated (~{big_lines / 1e6:.1f} M lines)",
                repeat_layers(out[0][1], big_lines),
            )
        )
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="runs per file; the median is reported")
    ap.add_argument("--big-lines", type=int, default=1_000_000, help="size of the large files")
    args = ap.parse_args(argv)
    rows = []
    for name, data in files(args.big_lines):
        program = gcode.parse(data)
        n = program.n_lines
        rep = args.repeat if n < 200_000 else max(3, args.repeat // 2)
        t, wall = median_time(lambda d=data: gcode.parse(d), rep)
        t_ref, _ = median_time(lambda d=data: python_reference(d), rep)
        rows.append((name, n, len(program.moves), len(program.layers), t, wall, n / t, n / t_ref))
    w = max(len(r[0]) for r in rows)
    print(
        f"{'file':<{w}}  {'lines':>9}  {'moves':>9}  {'layers':>6}  {'cpu s':>7}  {'wall s':>7}  "
        f"{'lines/s (cpu)':>13}  {'vs target':>9}  {'py split lines/s':>16}  {'ratio':>6}"
    )
    for name, n, moves, layers, t, wall, rate, ref in rows:
        print(
            f"{name:<{w}}  {n:>9}  {moves:>9}  {layers:>6}  {t:>7.3f}  {wall:>7.3f}  {rate:>13,.0f}  "
            f"{rate / TARGET:>8.2f}x  {ref:>16,.0f}  {rate / ref:>5.2f}x"
        )
    print(
        f"median of {args.repeat} runs (3+ for files over 200k lines); lines/s from the process's CPU time "
        "on "
        f"one core (OMP/BLAS threads = 1); target {TARGET:,} lines/s; 'ratio' = parse rate / a minimal "
        "Python split of the same text (splitlines + split, no numbers)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
