"""The splice alone (issue 17, "a splice that streams"): output lines per CPU second, and where it goes.

Usage::

    python benchmarks/bench_splice.py [OUT_DIR] [--repeats 3] [--only specimen-100,example]
                                      [--engine swarm] [--profile 25] [--no-check]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

Parts: ``example`` (the shipped ``examples/ohs.gcode`` with ``examples/ohs.toml``) and
``specimen-100`` (the specimen's outline 20 mm thick, 100 layers, sliced by PrusaSlicer with the
example's settings, ``tests/slicing.py``; load case ``tests/cases.py`` ``GRIP_PULL``).

Each part is run once through the whole pipeline (``loadpath.plugin.job.run_job``, no verdict) with
``LOADPATH_CACHE_DIR`` in ``OUT_DIR/cache``; the arguments the pipeline hands to
:func:`loadpath.splice.splice` (the block fills and the splice options) are caught and pickled to
``OUT_DIR/PART.splice.pickle``.  A later run with the same ``OUT_DIR`` starts from that pickle, so
the splice is timed on exactly the same fills before and after a change to the splicer (the
splicer's code is in no cache key but the simplified paths', :data:`loadpath.cache.UNRELATED`).

Then, in this process, the input is parsed (not timed) and the splice and its check
(:func:`loadpath.splice.check_output`) are timed in CPU seconds (``time.process_time``), median of
``--repeats``.  Printed per part: output lines and the lines the splice wrote (its edits), output
lines per CPU second of the splice (one process: per core), the check's CPU seconds and lines per
second, and the ``--profile`` top functions of one more splice under ``cProfile`` (own time;
the profiler roughly doubles the time of small Python calls).  ``OUT_DIR/bench_splice.json`` keeps
the rows.  Default ``OUT_DIR``: ``$TMPDIR/loadpath_bench_splice``.

Measured 2026-12-04 (issue 17, "a splice that streams"), engine swarm, the same pickled fills,
BEFORE = 08f331b (its ``core`` as ``loadpath`` on ``PYTHONPATH``) and AFTER = this branch, run
alternately four times each (``--repeats 1``) on the 2-core machine shared with other jobs (load
2-4); medians::

    part          out lines   splice s BEFORE  AFTER   lines/s BEFORE  AFTER   check s BEFORE  AFTER
    example           24499            0.368   0.107             67 k  229 k            0.065  0.032
    specimen-100     399296            6.69    2.36              60 k  169 k            0.435  0.395

The check's code is the same; it most likely ran faster after because no matrix product before it
had woken OpenBLAS's threads (below).  Byte-identical outputs (sha256 of the splice's bytes).

Where the time was, and went (``--profile``, specimen-100): the Writer's number formatting, three
``str`` list comprehensions per chain (now one numpy pass per block, :mod:`loadpath.splice.numtext`);
the 2-opt rebuilding where every path starts and ends at each step; and, largest, ``xy @ [1, 1j]``
in ``bead_runs``: a float-by-complex matrix product, about 10 ms of CPU per block of 7000 vertices
(with it gone, every other item of the profile, whose clock is the wall's, took about a third of
its time: most likely OpenBLAS's threads, woken by the product, contended for the 2 cores).
Left (a profile of about 3 s; 2.0-2.4 s without the profiler): per chain, the travel with its
retraction and wipe (25 %: shapely's ``covers``, the wipe's moves formatted one at a time), the
chain's E and markers in ``extrude_many`` (16 %); per block, the plan's order (greedy and 2-opt,
14 %) and the bead runs with their Ramer-Douglas-Peucker passes (20 %).  The 1 M lines/s target is
not met: what is left is Python per chain (4414 chains in 98 blocks: about 0.5 ms of the splice
per chain), not per vertex.

Measured 2026-12-04 22:25 UTC (issue 17, second splice pass: number digits from tables, the greedy
order from the 2-opt's cost table, a block's wipes, width-marker candidates and chain times in one
pass each), the same pickled fills, BEFORE = 89dc3f2 (main, its ``core`` as ``loadpath`` on
``PYTHONPATH``) and AFTER = branch ``splicefast``, run alternately (``--profile 0``; specimen-100
``--repeats 3`` four times each, specimen-1000 ``--repeats 1`` twice each) at load 2.6-3.5 on the
2 cores (other jobs)::

    part           out lines   splice s BEFORE        AFTER                lines/s BEFORE  AFTER
    specimen-100      392269   1.97 2.31 2.01 2.17    1.85 2.04 1.78 1.75  170-199 k     192-225 k
    specimen-1000    3968985   19.39 19.17            17.68 17.49          205-207 k     225-227 k

Byte-identical outputs (sha256 of the splice's bytes; the 42 splice calls of ``tests/splice`` replayed
on both versions from the same inputs).  The check is unchanged (3.3-3.4 s, 1.16-1.19 M lines/s on
the 1000-layer file).  Where the 1000-layer splice's 17.9 s went after (one process, timers):
bead runs 7.9 s (their two Ramer-Douglas-Peucker passes per block about 60 % of it: element-wise
work over about 3 visits per vertex, 11-16 levels), the rewrite 7.3 s (the blocks' text 2.3, the
travels between chains 1.5, the chains' extrusion 1.1), the plan 1.9 s.  The 1 M lines/s target is
still missed by 4.4x: the numpy passes left are work, not per-call overhead (the RDP of 8 blocks
batched into one call: 0.43 -> 0.36 s), and the sequential parts (runs of one width, the markers'
hysteresis, the E carry through retractions) are plain-float loops already.
"""

from __future__ import annotations

import argparse
import cProfile
import hashlib
import io
import json
import os
import pickle
import pstats
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
import slicing  # noqa: E402
from cases import GRIP_PULL  # noqa: E402


def _prepare(name: str, folder: Path, engine: str) -> tuple[Path, Path]:
    """The part's G-code and the pickle of its splice arguments (made on first use)."""
    if name == "example":
        gcode, case = REPO / "examples" / "ohs.gcode", REPO / "examples" / "ohs.toml"
    else:
        layers = {"specimen-100": 100, "specimen-200": 200, "specimen-1000": 1000}[name]
        gcode, case = folder / f"{name}.gcode", folder / "grip_pull.toml"
        case.write_text(GRIP_PULL, encoding="utf-8")
        if not gcode.exists():
            stl = slicing.write_stl(slicing.ohs_mesh(thickness=0.2 * layers), folder / f"{name}.stl")
            slicing.slice_prusa(stl, gcode, **slicing.PRUSA_EXAMPLE)
    caught = folder / f"{name}.{engine}.splice.pickle"
    if caught.exists():
        return gcode, caught
    import loadpath.pipeline as pipeline
    from loadpath.plugin.job import JobRequest, run_job

    real = pipeline.splice
    args: list = []

    def catch(program, fills, options, **kw):  # kw: the pipeline's workers
        fills = list(fills)
        args.append((fills, options))
        return real(program, fills, options, **kw)

    os.environ["LOADPATH_CACHE_DIR"] = str(folder / "cache")
    pipeline.splice = catch
    try:
        out = folder / f"{name}.{engine}.out.gcode"
        res = run_job(JobRequest(gcode, case, output=out, cli={"engine": engine}, predict=False))
    finally:
        pipeline.splice = real
    if res.error or not args:
        raise SystemExit(f"{name}: the pipeline did not splice ({res.error or 'nothing replaced'})")
    caught.write_bytes(pickle.dumps(args[0], protocol=pickle.HIGHEST_PROTOCOL))
    return gcode, caught


def _profile(call, top: int) -> list[str]:
    prof = cProfile.Profile()
    prof.enable()
    call()
    prof.disable()
    buf = io.StringIO()
    st = pstats.Stats(prof, stream=buf)
    st.sort_stats("tottime").print_stats(top)
    text = buf.getvalue().splitlines()
    head = next(i for i, t in enumerate(text) if t.strip().startswith("ncalls"))
    return [t for t in text[head:] if t.strip()]


def bench(name: str, folder: Path, repeats: int, engine: str, top: int, check: bool) -> dict:
    """One part: splice and check CPU seconds, lines per second, profile."""
    from loadpath import gcode as gc
    from loadpath.splice import check_output, splice

    gcode, caught = _prepare(name, folder, engine)
    fills, options = pickle.loads(caught.read_bytes())
    program = gc.read(gcode)
    cpu, cpu_check, res = [], [], None
    for _ in range(repeats):
        t = time.process_time()
        res = splice(program, fills, options)
        cpu.append(time.process_time() - t)
        if check:
            regions = {f.block: f.region for f in fills if f.region is not None}
            t = time.process_time()
            r = options.motion.retraction.length
            chk = check_output(program, res.data, res, regions=regions, retract_length=r)
            cpu_check.append(time.process_time() - t)
            if chk.problems:
                raise SystemExit(f"{name}: the check failed: {chk.problems[0]}")
    assert res is not None
    out_lines = res.data.count(b"\n")
    new_lines = sum(k for _, _, k in res.edits)
    s = statistics.median(cpu)
    row = {
        "part": name,
        "engine": engine,
        "blocks": len(res.blocks),
        "in_lines": program.n_lines,
        "out_lines": out_lines,
        "new_lines": new_lines,
        "splice_cpu_s": s,
        "splice_cpu_s_all": cpu,
        "out_lines_per_s": out_lines / s,
        "new_lines_per_s": new_lines / s,
        "sha256": hashlib.sha256(res.data).hexdigest(),
    }
    if cpu_check:
        row["check_cpu_s"] = statistics.median(cpu_check)
        row["check_out_lines_per_s"] = out_lines / row["check_cpu_s"]
    if top:
        row["profile"] = _profile(lambda: splice(program, fills, options), top)
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, nargs="?", default=None, help="working folder (kept between runs)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", default="example,specimen-100", help="comma-separated part names")
    from loadpath.engines import NAMES
    ap.add_argument("--engine", default="swarm", choices=tuple(NAMES))
    ap.add_argument("--profile", type=int, default=25, help="top functions shown (0: no profile)")
    ap.add_argument("--no-check", action="store_true", help="time the splice only")
    args, _ = ap.parse_known_args(argv)
    folder = args.out or Path(tempfile.gettempdir()) / "loadpath_bench_splice"
    folder.mkdir(parents=True, exist_ok=True)
    if shutil.which("prusa-slicer") is None and args.only != "example":
        print("(PrusaSlicer not found: the specimen cannot be sliced unless its G-code is in the folder)")
    rows = []
    print(
        f"splice alone, CPU seconds, median of {args.repeats}; engine {args.engine}; load average "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; folder {folder}",
        flush=True,
    )
    head = (
        f"{'part':<14}{'blocks':>7}{'out lines':>11}{'new lines':>11}{'splice s':>10}{'lines/s':>11}"
        f"{'check s':>9}{'lines/s':>11}"
    )
    print(head)
    print("-" * len(head), flush=True)
    for name in args.only.split(","):
        r = bench(name, folder, max(1, args.repeats), args.engine, args.profile, not args.no_check)
        rows.append(r)
        print(
            f"{r['part']:<14}{r['blocks']:>7}{r['out_lines']:>11}{r['new_lines']:>11}"
            f"{r['splice_cpu_s']:>10.3f}"
            f"{r['out_lines_per_s']:>11.0f}{r.get('check_cpu_s', float('nan')):>9.3f}"
            f"{r.get('check_out_lines_per_s', float('nan')):>11.0f}",
            flush=True,
        )
    for r in rows:
        if "profile" in r:
            print(f"\n{r['part']}: profile of one splice (own time)")
            print("\n".join(r["profile"]))
    (folder / "bench_splice.json").write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
