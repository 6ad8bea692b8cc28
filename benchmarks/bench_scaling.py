"""All cores for one file (issue 17): ``loadpath run`` on 1, 2, ... N worker processes, side by side.

Usage::

    python benchmarks/bench_scaling.py [OUT_DIR] [--repeats 2] [--jobs 1,2,4] [--only specimen-100,...]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

One file is reprocessed with ``--set jobs=N`` for each N (default 1, 2, ..., the machine's cores,
and twice that to show oversubscription), as whole processes, each run on an empty cache (a first
run: every stage's work is done) and then, against the cache that run filled, on the part re-sliced
at other speeds (a repeat), median of ``--repeats`` in turn over N so that the machine's load falls
on every N alike.  The parts (PrusaSlicer 2.5 slices made here, ``bench_latency.py``'s settings
and clamp-and-pull load case):

``specimen-100``
    the open-hole specimen's outline 20 mm thick, 100 layers (solid infill replaced);
``gusset-gyroid30-sparse``
    the shelf gusset at 30 % gyroid with ``--replace solid,sparse`` (density ``auto``: two
    candidates laid, linked and judged);
``specimen-1000``
    the outline 200 mm tall: 1000 layers, 23 MB.

Per part and N: first and repeat wall seconds, their speedup over one worker, CPU seconds of the
run (user + system of the process and its workers) and peak resident memory.  What runs on several
workers: the layers' islands, the engine runs, the links, the splice's blocks, the splice check's
groups of pieces, the verdict's two predictions; parsing, the FEA and writing run in the main
process, so the speedup stays under N.  ``OUT_DIR/bench_scaling.json`` keeps the rows.

Measured 2026-12-05 08:07-08:20 UTC on the 2-core development machine (main 8acf617, load 0.3 at
the start), ``--repeats 2``::

    part                     jobs  first s    x1  repeat s    x1  cpu first  cpu rep  peak MB
    specimen-100                1     6.33  1.00      3.41  1.00        6.6      3.5      449
    specimen-100                2     4.78  1.32      2.19  1.55        7.5      3.7      322
    specimen-100                4     4.61  1.37      2.27  1.50        7.4      3.9      322
    gusset-gyroid30-sparse      1    17.45  1.00     10.29  1.00       17.8     10.6      346
    gusset-gyroid30-sparse      2    12.67  1.38      8.30  1.24       18.9     11.4      328
    gusset-gyroid30-sparse      4    12.68  1.38      8.50  1.21       19.6     12.1      327
    specimen-1000               1    29.47  1.00     21.94  1.00       29.7     22.1      810
    specimen-1000               2    18.42  1.60     13.98  1.57       31.3     23.1      721
    specimen-1000               4    18.91  1.56     14.18  1.55       32.2     23.7      720

Two workers on two cores: 1.32-1.60x the one-worker speed, most on the 1000-layer file (its splice
and check are most of its time and both split evenly); four workers on two cores gain nothing
more.  The CPU seconds grow by 5-14 % from one worker to two (the forks' copies, each worker's
imports).  The rest is the main process's serial stages: on the 1000-layer first run about 4 s
(parse 1.3 s, FEA 0.4 s, the splice's assembly 0.3-0.8 s, verdict, write, start-up), on the
sparse gusset the verdict's candidate judgments (three predictions of ``compare``'s model, one
after the other).  The peak memory is higher with one worker (449 against 322 MB on the 100-layer
specimen, 810 against 721 MB on the 1000-layer file); not explained here.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "benchmarks"))
import slicing  # noqa: E402
from bench_latency import GUSSET, LOADPATH, OTHER_SPEEDS, gusset_mesh  # noqa: E402
from bench_pipeline import _child  # noqa: E402
from cases import GRIP_PULL  # noqa: E402

PARTS = {
    "specimen-100": ("specimen", 20.0, slicing.PRUSA_EXAMPLE, []),
    "gusset-gyroid30-sparse": ("gusset", None, GUSSET, ["--replace", "solid,sparse"]),
    "specimen-1000": ("specimen", 200.0, slicing.PRUSA_EXAMPLE, []),
}


def _cpu() -> float:
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def _slices(name: str, folder: Path) -> tuple[Path, Path]:
    """The part's slice and its re-slice at other speeds (made once)."""
    shape, height, settings, _ = PARTS[name]
    stl = folder / f"{name}.stl"
    mesh = gusset_mesh() if shape == "gusset" else slicing.ohs_mesh(thickness=height)
    slicing.write_stl(mesh, stl)
    first, other = folder / f"{name}.gcode", folder / f"{name}.speeds.gcode"
    slicing.slice_prusa(stl, first, **settings)
    slicing.slice_prusa(stl, other, **{**settings, **OTHER_SPEEDS})
    return first, other


def _run(gcode: Path, case: Path, out: Path, cache: Path, jobs: int, extra: list[str], timeout: float):
    env = {**os.environ, "LOADPATH_CACHE_DIR": str(cache)}
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as an installed loadpath runs (bench_latency.py)
    cmd = [LOADPATH, "run", str(gcode), "--loadcase", str(case), "-o", str(out)]
    cmd += ["--set", f"jobs={jobs}", *extra]
    c = _cpu()
    wall, rss, status, err = _child(cmd, timeout=timeout, env=env)
    if status != 0:
        raise SystemExit(f"loadpath run failed on {gcode.name} with jobs={jobs}: {err}")
    return wall, _cpu() - c, rss


def bench(name: str, folder: Path, jobs: list[int], repeats: int, timeout: float) -> list[dict]:
    """One part: per N, first and repeat medians (wall, CPU, peak memory)."""
    case = folder / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    first, other = _slices(name, folder)
    extra = PARTS[name][3]
    got: dict[int, dict[str, list[float]]] = {n: {} for n in jobs}
    for r in range(repeats):
        for n in jobs:  # in turn: the machine's load falls on every N alike
            cache = folder / f"cache-{name}-{n}-{r}"
            for kind, src in (("first", first), ("repeat", other)):
                out = folder / f"{name}.{kind}.out.gcode"
                wall, cpu, rss = _run(src, case, out, cache, n, extra, timeout)
                for key, v in ((kind, wall), (f"{kind}_cpu", cpu), ("rss", rss)):
                    got[n].setdefault(key, []).append(v)
    rows = []
    for n in jobs:
        g = got[n]
        rows.append({
            "part": name, "jobs": n,
            "first_s": statistics.median(g["first"]), "repeat_s": statistics.median(g["repeat"]),
            "first_cpu_s": statistics.median(g["first_cpu"]),
            "repeat_cpu_s": statistics.median(g["repeat_cpu"]),
            "peak_rss_mb": max(g["rss"]), "first_all": g["first"], "repeat_all": g["repeat"],
        })
    one = rows[0]
    for row in rows:
        row["first_speedup"] = one["first_s"] / row["first_s"]
        row["repeat_speedup"] = one["repeat_s"] / row["repeat_s"]
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, nargs="?", default=None, help="folder for bench_scaling.json")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--jobs", default=None, help="worker counts (default 1..cores and 2 x cores)")
    ap.add_argument("--only", default=None, help="comma-separated part names")
    ap.add_argument("--timeout", type=float, default=900.0)
    ap.add_argument("--quick", action="store_true", help="one repeat, the 100-layer specimen only")
    args, _ = ap.parse_known_args(argv)
    cores = os.cpu_count() or 1
    jobs = [int(j) for j in args.jobs.split(",")] if args.jobs else [*range(1, cores + 1), 2 * cores]
    if jobs[0] != 1:
        jobs = [1, *jobs]
    names = list(PARTS)
    if args.quick:
        names = ["specimen-100"]
    if args.only:
        names = [n for n in names if n in set(args.only.split(","))]
    repeats = 1 if args.quick else max(1, args.repeats)
    print(
        f"loadpath run on 1..N workers (--set jobs=N), whole processes, median of {repeats}; "
        f"{slicing.prusa_version()}; load average {os.getloadavg()[0]:.1f} on {cores} cores",
        flush=True,
    )
    head = (
        f"{'part':<24}{'jobs':>5}{'first s':>9}{'x1':>6}{'repeat s':>10}{'x1':>6}"
        f"{'cpu first':>11}{'cpu rep':>9}{'peak MB':>9}"
    )
    print(head)
    print("-" * len(head), flush=True)
    rows: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="bench_scaling_") as tmp:
        for name in names:
            for r in bench(name, Path(tmp), jobs, repeats, args.timeout):
                rows.append(r)
                print(
                    f"{r['part']:<24}{r['jobs']:>5}{r['first_s']:>9.2f}{r['first_speedup']:>6.2f}"
                    f"{r['repeat_s']:>10.2f}{r['repeat_speedup']:>6.2f}{r['first_cpu_s']:>11.1f}"
                    f"{r['repeat_cpu_s']:>9.1f}{r['peak_rss_mb']:>9.0f}",
                    flush=True,
                )
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "bench_scaling.json").write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
