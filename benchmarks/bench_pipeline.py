"""End-to-end benchmark of ``loadpath run``: wall time with interpreter start, time per stage, peak memory,
beside the time PrusaSlicer 2.5 takes to slice the same part (issue 6, Performance).

Usage::

    python benchmarks/bench_pipeline.py [OUT_DIR] [--repeats 3] [--quick] [--engine swarm] [--tall]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

Parts (sliced by the real PrusaSlicer with the MK3S presets and the shipped example's settings:
100 % rectilinear, 3 top / 3 bottom solid layers; load case: clamped at x_min, pulled at x_max):

``specimen``
    the shipped example (``examples/ohs.gcode``): 150 x 36 x 2 mm open-hole specimen, 10 layers.
    Target: under 3 s including interpreter start.
``specimen-20mm``
    the same outline 20 mm thick: 100 layers of one region (one FEA, paths reused on every layer).
``tower``
    a twisted, tapered 24 mm plate with a hole (``tests/slicing.py``): 120 layers whose outline
    changes every layer, so every layer needs its own paths (3D FEA).  Skipped with ``--quick``.
``specimen-200mm`` (``--tall`` only)
    the specimen's outline 200 mm tall: 1000 layers, about 1000 replaced blocks, 842k lines and
    23 MB in, 4.6M lines out.  The splice stage (bead runs and their simplification, per block) and
    the check (the whole output re-read) dominate; the peak memory is the check's.  Issue 6
    follow-up, same paths spliced before and after (byte-identical output): splice CPU 118 -> 107 s
    (``plan.simplify`` 18.2 -> 5.6 ms per block; the rest is the rewriter and G-code writer); check
    alone 11.8 -> 8.6 s and +1.71 -> +1.00 GB; ``loadpath run`` peak RSS 2.45 -> 1.78 GB (all
    under load from other jobs).

For each part: PrusaSlicer's own slicing time (median of the repeats), ``loadpath run`` as a fresh
process (median wall time, peak resident memory of that process from ``wait4``), the input's size
and the output's size against it (``out/in``), the interpreter and
import time alone (``loadpath --help``), and the stages measured inside one in-process run.  The
results go to ``OUT_DIR/bench_pipeline.json`` when a folder is given.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
import slicing  # noqa: E402
from cases import GRIP_PULL  # noqa: E402
from loadpath import engines  # noqa: E402

LOADPATH = str(Path(sys.executable).with_name("loadpath"))
CASE = GRIP_PULL
STAGES = ("parse", "geometry", "loadcase", "fea", "paths", "splice", "check", "write")


def _child(
    cmd: list[str], timeout: float | None = None, env: dict[str, str] | None = None
) -> tuple[float, float, int, str]:
    """Run a command; (wall s, peak RSS MB, exit status, stderr tail).  Killed after ``timeout`` s."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    deadline = None if timeout is None else t + timeout
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if deadline is not None and time.perf_counter() > deadline:
            proc.kill()
            _, status, usage = os.wait4(proc.pid, 0)
            return float("inf"), usage.ru_maxrss / 1024.0, -9, f"killed after {timeout:.0f} s"
        time.sleep(0.02)
    wall = time.perf_counter() - t
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    lines = err.strip().splitlines()
    return wall, usage.ru_maxrss / 1024.0, os.waitstatus_to_exitcode(status), lines[-1] if lines else ""


def _slice(stl: Path, out: Path, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        slicing.slice_prusa(stl, out, **slicing.PRUSA_EXAMPLE)
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def _stages(gcode: Path, case: Path, out: Path, engine: str) -> dict[str, float]:
    from loadpath.plugin.job import JobRequest, run_job

    res = run_job(JobRequest(gcode, case, output=out, cli={"engine": engine}))
    times = dict(res.times)
    p = res.pipeline
    times["engine_runs"] = float(len(p.jobs)) if p else 0.0
    times["layers_replaced"] = float(len(p.splice.blocks)) if p and p.splice else 0.0
    return times


def bench(
    name: str, stl: Path | None, gcode: Path | None, folder: Path, repeats: int, engine: str, timeout: float
) -> dict:
    case = folder / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    row: dict = {"part": name, "engine": engine}
    if stl is not None:
        gcode = folder / f"{name}.gcode"
        row["prusaslicer_s"] = _slice(stl, gcode, repeats)
    else:
        row["prusaslicer_s"] = _slice(folder / "ohs.stl", folder / "ohs-reslice.gcode", repeats)
    from loadpath import gcode as gc

    row["layers"] = len(gc.read(gcode).layers)
    out = folder / f"{name}.loadpath.gcode"
    walls, rss = [], []
    for _ in range(repeats):
        w, m, status, err = _child(
            [LOADPATH, "run", str(gcode), "--loadcase", str(case), "-o", str(out), "--engine", engine]
        )
        if status != 0:
            raise SystemExit(f"loadpath run failed on {name}: {err}")
        walls.append(w)
        rss.append(m)
    row["run_s"] = statistics.median(walls)
    row["run_s_all"] = walls
    row["peak_rss_mb"] = max(rss)
    row["stages_s"] = _stages(gcode, case, folder / f"{name}.inproc.gcode", engine)
    row["size_in_mb"] = gcode.stat().st_size / 1e6
    row["size_out_mb"] = out.stat().st_size / 1e6
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, nargs="?", default=None, help="folder for bench_pipeline.json")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="specimen and the 100-layer specimen only")
    ap.add_argument("--engine", default="swarm", choices=engines.NAMES)
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds before a run is given up")
    ap.add_argument("--tall", action="store_true", help="also the 1000-layer specimen (about 5 minutes)")
    args, _ = ap.parse_known_args(argv)
    rows = []
    head = f"{'part':<15}{'layers':>7}{'slice s':>9}{'run s':>8}{'ratio':>7}{'peak MB':>9}"
    head += f"{'in MB':>7}{'out/in':>7}{'runs':>6}"
    head += "  stages (s)"

    def show(r: dict) -> None:
        st = r["stages_s"]
        if not st:
            print(
                f"{r['part']:<15}{r['layers']:>7}{r['prusaslicer_s']:>9.2f}  {r.get('note', '')}", flush=True
            )
            return
        stages = " ".join(f"{k} {st.get(k, 0.0):.2f}" for k in STAGES)
        print(
            f"{r['part']:<15}{r['layers']:>7}{r['prusaslicer_s']:>9.2f}{r['run_s']:>8.2f}"
            f"{r['run_s'] / r['prusaslicer_s']:>7.0f}{r['peak_rss_mb']:>9.0f}"
            f"{r['size_in_mb']:>7.1f}{r['size_out_mb'] / r['size_in_mb']:>7.2f}"
            f"{st['engine_runs']:>6.0f}  {stages}",
            flush=True,
        )

    with tempfile.TemporaryDirectory(prefix="bench_pipeline_") as tmp:
        folder = Path(tmp)
        slicing.write_stl(slicing.ohs_mesh(), folder / "ohs.stl")
        start = statistics.median(_child([LOADPATH, "--help"])[0] for _ in range(args.repeats))
        print(
            f"loadpath run, end to end (fresh process, median of {args.repeats}); engine {args.engine}; "
            f"{slicing.prusa_version()}; interpreter + imports (loadpath --help): {start:.2f} s; "
            f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores",
            flush=True,
        )
        print(head)
        print("-" * len(head), flush=True)
        ex = REPO / "examples" / "ohs.gcode"
        rows.append(bench("specimen", None, ex, folder, args.repeats, args.engine, args.timeout))
        show(rows[-1])
        thick = slicing.write_stl(slicing.ohs_mesh(thickness=20.0), folder / "ohs20.stl")
        rows.append(
            bench("specimen-20mm", thick, None, folder, max(1, args.repeats // 2), args.engine, args.timeout)
        )
        show(rows[-1])
        if not args.quick:
            tower = slicing.write_stl(slicing.tower_mesh(), folder / "tower.stl")
            rows.append(bench("tower", tower, None, folder, 1, args.engine, args.timeout))
            show(rows[-1])
        if args.tall:
            tall = slicing.write_stl(slicing.ohs_mesh(thickness=200.0), folder / "ohs200.stl")
            rows.append(bench("specimen-200mm", tall, None, folder, 1, args.engine, args.timeout))
            show(rows[-1])
    spec = rows[0]["run_s"]
    print(
        f"\nspecimen target: < 3 s including interpreter start; measured {spec:.2f} s "
        f"({'met' if spec < 3 else 'missed'})"
    )
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "bench_pipeline.json").write_text(json.dumps({"start_s": start, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
