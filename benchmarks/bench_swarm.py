"""Swarm engine benchmark: the paper's Section IV-A (Table 1, Fig. 6, Fig. 7) and the other test regions.

Usage::

    python benchmarks/bench_swarm.py OUT_DIR [--repeats 5] [--quick] [--speed-only] [--no-compile]

Prints, for one slice of the open-hole specimen (150 x 36 x 2 mm, 6 mm hole, 1000 N tension at
x_max, clamped at x_min, l = 0.4 mm) and K = 0.5, 5, 50: beta (Eq. 14) overall and where the field
curves, the spacing variance (both definitions of loadpath.metrics), time per slice (median of the
repeats, one core), coverage and overlap (flow-width beads = local pitch), beside the paper's Table 1
and the slicer's own rectilinear infill at the same pitch.  Two stress fields:

* ``fea``: the in-house FEA (loadpath.fea, plane stress, quadratic triangles) of the load case
  ``examples/ohs.toml``; virtual mass normalised by the largest principal stress away from the
  supports and loads (the paper's footnote 1: ``m = |s| / max |s|``, here the peak at the hole);
* ``kirsch``: Kirsch's closed form (infinite plate with a hole) restricted to the specimen.

Time per slice is given cold (the field's raster built inside the call, as for the first layer of
a body) and warm (raster reused, as for every further layer of a 2D analysis).  Then: how low beta
goes (K down to 0.01, and the bare algorithm without this engine's additions), a K sweep
for the "beyond the paper" item, the 200 x 200 mm layer with three holes (real FEA), and coverage /
overlap / crossings on the other test regions (an L-bracket with a real bearing load on its bolt
hole, fixed at the other leg).  PNGs (paths around the hole, spacing histograms, the L-bracket) go
to OUT_DIR.

First, the compiled kernels (numba): the cold compile (a new process with an empty
``NUMBA_CACHE_DIR``, as on a clean clone), the load from the on-disk cache (a second process), and
the warm time per layer at K = 0.5 / 5 / 50 beside the numpy engine the kernels replaced (the
swarm package as of commit 2344ebc^, taken from git history into a temporary package; skipped
without git history) in the same run.  ``--speed-only`` stops after that section.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import re  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import shapely  # noqa: E402
from loadpath import metrics as M  # noqa: E402
from loadpath.engines.swarm import generate  # noqa: E402
from loadpath.engines.swarm.raster import clear_cache  # noqa: E402
from loadpath.fea import analyze  # noqa: E402
from loadpath.field import AnalyticField, kirsch_tensor  # noqa: E402
from loadpath.loadcase import Body, parse, read, resolve  # noqa: E402
from loadpath.toolpath import EngineInput  # noqa: E402
from shapely.geometry import LineString, MultiPolygon, Point, Polygon, box  # noqa: E402

PITCH = 0.4
PAPER = {0.5: (0.981, 6.1e-3), 5.0: (0.993, 12.9e-3), 50.0: (0.998, 16.4e-3)}
PAPER_TIME_S = 0.198
REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
from cases import END_PULL, side_case  # noqa: E402

# the paper's specimen (Fig. 5): clamped at x_min, pulled through the end face at x_max (the shipped
# examples/ohs.toml, with its material and a 1 mm pull window, is printed as a second line)
OHS_CASE = END_PULL

BRACKET_CASE = """
version = 1
[[supports]]
name = "wall"
where = { side = "y_max", within = 1.0 }
fix = ["x", "y", "z"]
[[loads]]
name = "bolt"
where = { hole_near = [52.5, 7.5], radius = 5.0 }
force = [0.0, -300.0, 0.0]
"""

PLATE_CASE = side_case((5000.0, 0.0, 0.0), held_within=5.0, loaded_within=5.0)


def specimen_region():
    return box(0, 0, 150, 36).difference(Point(75, 18).buffer(3, quad_segs=64))


def fea_case(name, region, case_text, thickness, scale_percentile=99.0, case_path=None):
    """Region, FE stress field of its middle layer, load entry, FEA seconds."""
    t0 = time.perf_counter()
    lc = read(case_path) if case_path is not None else parse(case_text)
    (rb,) = resolve(lc, [Body.from_layers(name, [(0.0, thickness, region)])])
    an = analyze(rb, pitch=PITCH, scale_percentile=scale_percentile)
    z = 0.5 * thickness
    field = an.field(z)
    # the start line loadpath run gives the engine: the field's load entry (ResolvedBody.load_entry,
    # what the load selectors picked), not the paper-rule filter of engines/swarm/entry.py
    return region, field, field.load_entry, time.perf_counter() - t0


def kirsch_specimen():
    region = specimen_region()
    field = AnalyticField(lambda p: kirsch_tensor(p, (75, 18), 3.0, 1.0), region, scale=3.0)
    return region, field, LineString([(150, 0), (150, 36)])


def uniform(angle_deg):
    a = np.deg2rad(angle_deg)
    c, s = np.cos(a), np.sin(a)
    return lambda p: np.tile([c * c, s * s, c * s], (len(p), 1))


# Times are CPU seconds of this process (time.process_time): the machine is shared with other
# jobs, so wall time measures the queue as much as the work; the wall times are printed too.
WALL: list[float] = []
CPU: list[float] = []


def timed(inp, K, repeats, **kw):
    """Cold CPU time (raster built in the call), median warm CPU time, the paths of the last run."""
    clear_cache()
    t0, w0 = time.process_time(), time.perf_counter()
    tp = generate(inp, K=K, **kw)
    cold = time.process_time() - t0
    WALL.append(time.perf_counter() - w0)
    CPU.append(cold)
    warm = []
    for _ in range(max(0, repeats - 1)):
        t0, w0 = time.process_time(), time.perf_counter()
        tp = generate(inp, K=K, **kw)
        warm.append(time.process_time() - t0)
        WALL.append(time.perf_counter() - w0)
        CPU.append(warm[-1])
    return tp, cold, statistics.median(warm) if warm else cold


# --------------------------------------------------------------------------- compile and speed

NUMPY_COMMIT = "2344ebc^"
"""The last commit whose swarm step ran in numpy (the numba kernels came with 2344ebc)."""

_CHILD = (
    "import time; t0 = time.process_time(); w0 = time.perf_counter();"
    "from loadpath.engines.swarm import kernel_step, warmup;"
    "t1 = time.process_time(); w1 = time.perf_counter();"
    "warmup.warm_up();"
    "print('TIMES', t1 - t0, time.process_time() - t1, time.perf_counter() - w1)"
)


def _child_times(env) -> tuple[float, float, float]:
    """Import CPU s, warm-up CPU s, warm-up wall s of a new process (warm-up: a tiny layer)."""
    out = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, check=True)
    m = re.search(r"TIMES (\S+) (\S+) (\S+)", out.stdout)
    if m is None:
        raise RuntimeError(f"no times from the compile child: {out.stdout!r} {out.stderr!r}")
    return float(m.group(1)), float(m.group(2)), float(m.group(3))


def compile_times() -> None:
    """Print the cold compile and the cache load of the kernels (new processes, empty cache dir)."""
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        imp, cold, cold_wall = _child_times(env)
        imp2, load, load_wall = _child_times(env)
    print(
        f"cold compile (empty cache, new process, tiny layer): {cold:6.1f} s CPU ({cold_wall:.1f} s wall;"
        f" imports {imp:.1f} s)"
    )
    print(
        f"from the cache (second process, tiny layer):        {load:6.2f} s CPU ({load_wall:.2f} s wall;"
        f" imports {imp2:.1f} s)"
    )


def numpy_engine(tmp: Path):
    """``generate`` of the numpy swarm engine (:data:`NUMPY_COMMIT`), or None without git history."""
    pkg = tmp / "_swarm_numpy"
    pkg.mkdir()
    try:
        names = subprocess.run(
            ["git", "-C", str(REPO), "ls-tree", "--name-only", NUMPY_COMMIT, "core/engines/swarm/"],
            capture_output=True, text=True, check=True,
        ).stdout.split()  # fmt: skip
        for name in names:
            src = subprocess.run(
                ["git", "-C", str(REPO), "show", f"{NUMPY_COMMIT}:{name}"],
                capture_output=True,
                text=True,
                check=True,
            ).stdout
            (pkg / Path(name).name).write_text(src.replace("loadpath.engines.swarm", "_swarm_numpy"))
    except (OSError, subprocess.CalledProcessError):
        return None
    sys.path.insert(0, str(tmp))
    import _swarm_numpy  # noqa: PLC0415

    return _swarm_numpy.generate


def speed(args, inp) -> None:
    """Warm CPU time per layer, compiled kernels against the numpy engine, same run, same layer."""
    with tempfile.TemporaryDirectory() as tmp:
        ref = numpy_engine(Path(tmp))
        print(
            f"{'K':>5}  {'numba ms':>9}  {'numpy ms':>9}  {'ratio':>6}   (CPU, median of {args.repeats};"
            f" paper 198 ms, target 50 ms; numpy = the engine as of {NUMPY_COMMIT})"
        )
        for K in (0.5, 5.0, 50.0):
            _, _, warm = timed(inp, K, args.repeats + 1)
            if ref is None:
                print(f"{K:5g}  {warm * 1e3:9.0f}  {'-':>9}  {'-':>6}")
                continue
            ref(inp, K=K)  # its raster cache, as the numba run's
            t = []
            for _ in range(args.repeats):
                t0 = time.process_time()
                ref(inp, K=K)
                t.append(time.process_time() - t0)
            ref_ms = statistics.median(t) * 1e3
            print(f"{K:5g}  {warm * 1e3:9.0f}  {ref_ms:9.0f}  {ref_ms / (warm * 1e3):6.1f}")


def fmt_row(name, m, t=None, paper=None):
    r = m.row()
    pb, pv = paper if paper else (float("nan"), float("nan"))
    ts = "         -" if t is None else f"{t[0] * 1e3:5.0f}/{t[1] * 1e3:4.0f}"
    return (
        f"{name:<18} {r['beta']:.4f} ({pb:.3f})  {r['beta_curved']:.4f}  "
        f"{r['next_var'] * 1e3:6.2f} ({pv * 1e3:5.1f})"
        f"  {r['spacing_var'] * 1e3:6.2f}  {r['spacing_min']:.2f}  {ts}  {r['coverage'] * 100:6.2f}"
        f"  {r['overlap'] * 100:5.2f}  {int(r['crossings']):3d}  {int(r['n_paths']):4d}"
    )


HEADER = (
    f"{'paths':<18} {'beta (paper)':<15} {'beta_c':<7} {'var_next e-3 (paper)':<20} {'var_near':<7} "
    f"{'min':<5} {'ms cold/warm':>10}  {'cov %':>6}  {'ovl %':>5}  {'x':>3}  {'n':>4}"
)


def plot_specimen(out: Path, runs, region, tag):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs), figsize=(5 * len(runs), 5))
    for ax, (K, tp) in zip(np.atleast_1d(axes), runs.items(), strict=True):
        for p in tp.paths:
            ax.plot(p.points[:, 0], p.points[:, 1], lw=0.6)
        for g in shapely.get_parts(region):
            for ring in [g.exterior, *g.interiors]:
                ax.plot(*ring.xy, "k", lw=0.8)
        ax.set_xlim(63, 87)
        ax.set_ylim(6, 30)
        ax.set_aspect("equal")
        ax.set_title(f"K = {K:g}")
    fig.suptitle(f"Swarm paths around the hole (paper Fig. 6), {tag} field")
    fig.savefig(out / f"fig6_paths_{tag}.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 4))
    for K, tp in runs.items():
        v = M.spacing(tp, PITCH, "next").values
        ax.hist(v, bins=np.linspace(0.4, 1.6, 61), histtype="step", density=True, label=f"K = {K:g}")
    ax.set_xlabel("distance to the following path / l")
    ax.legend()
    ax.set_title(f"Distribution of distances (paper Fig. 7), {tag} field")
    fig.savefig(out / f"fig7_spacing_{tag}.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(16, 4.5))
    for p in runs[5.0].paths:
        ax.plot(p.points[:, 0], p.points[:, 1], lw=0.4)
    ax.set_aspect("equal")
    ax.set_title(f"K = 5, whole specimen (paper Fig. 8), {tag} field")
    fig.savefig(out / f"fig8_specimen_{tag}.png", dpi=120)
    plt.close(fig)


def plot_paths(out: Path, tp, region, name):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 7))
    for p in tp.paths:
        ax.plot(p.points[:, 0], p.points[:, 1], lw=0.5)
    for g in shapely.get_parts(region):
        for ring in [g.exterior, *g.interiors]:
            ax.plot(*ring.xy, "k", lw=0.8)
    ax.set_aspect("equal")
    fig.savefig(out / name, dpi=120)
    plt.close(fig)


# The paper's kill/spawn rule (Sec. III-B6): every step, one kill candidate (the closest pair) and
# one spawn candidate (the widest pair) over the whole front, kept by Eq. 13.  The engine's default
# proposes one of each per window of 16 agents, only beyond 0.85 / 1.3 pitches.
PAPER_RULE = {"window": 10**6, "kill_below": 10.0, "spawn_above": 0.0}


BARE = {**PAPER_RULE, "fill": False, "extend_ends": False, "gaps": False, "centre": 0.0, "widths": "swarm"}


def floor(region, field, load):
    """How low beta goes: K far below the paper's 0.5, and the bare algorithm (no fill, no
    end extension, no gap beads, no centring; the paper's one kill or spawn per step).

    The QP's box lets an agent stray at most h/8 sideways from its ideal step with at least 3h/4
    of advance, an angle of atan(1/6) = 9.5 degrees (|cos| 0.986) even when every step saturates
    it; on the specimen's straight field a front at the pitch costs nothing where it follows the
    stress, so nothing pushes it off.
    """
    print("\nHow low beta goes (the paper's K = 0.5 gives 0.981), FEA field:")
    print(HEADER)
    inp = EngineInput(region=region, field=field, pitch=PITCH, load_entry=load)
    for name, K, kw in (
        ("K=0.05", 0.05, {}),
        ("K=0.01", 0.01, {}),
        ("bare K=0.5", 0.5, BARE),
        ("bare K=0.01", 0.01, BARE),
    ):
        tp, cold, warm = timed(inp, K, 1, **kw)
        print(fmt_row(name, M.evaluate(tp, region, field, PITCH), (cold, warm), PAPER[0.5]))
    bound = np.arctan(1 / 6)
    print(f"  the box's bound on a step's deviation: {np.degrees(bound):.1f} deg, |cos| {np.cos(bound):.4f}")


def table1(args, tag, region, field, load):
    inp = EngineInput(region=region, field=field, pitch=PITCH, load_entry=load)
    runs = {}
    print(HEADER)
    for K in (0.5, 5.0, 50.0):
        tp, cold, warm = timed(inp, K, args.repeats)
        runs[K] = tp
        print(fmt_row(f"swarm K={K:g}", M.evaluate(tp, region, field, PITCH), (cold, warm), PAPER[K]))
    for K in (0.5, 5.0, 50.0):
        tp, cold, warm = timed(inp, K, 1, **PAPER_RULE)
        print(fmt_row(f"paper rule K={K:g}", M.evaluate(tp, region, field, PITCH), (cold, warm), PAPER[K]))
    for name, m in M.baselines(region, field, PITCH).items():
        print(fmt_row(f"slicer {name}", m))
    st = runs[5.0].stats
    print(
        f"K = 5 last run (wall): raster {st['time_raster_s'] * 1e3:.0f} ms, "
        f"first swarm {st['time_first_swarm_s'] * 1e3:.0f} ms,"
        f" fill swarms {st['time_fill_s'] * 1e3:.0f} ms, widths {st.get('time_widths_s', 0) * 1e3:.0f} ms,"
        f" ends {st.get('time_ends_s', 0) * 1e3:.0f} ms, gap beads {st.get('time_gaps_s', 0) * 1e3:.0f} ms"
        f" (total {st['time_s'] * 1e3:.0f} ms); {st['steps']} steps, {st['qp_solves']} banded QP solves"
        f" ({st.get('qp_exact', 0)} exact, {st['qp_solves'] - st.get('qp_exact', 0)} OSQP fallbacks),"
        f" {st.get('kills', 0)} kills, {st.get('spawns', 0)} spawns, {st.get('swarms', 0)} swarms"
    )
    plot_specimen(args.out, runs, region, tag)
    return runs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="folder for the PNG plots")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="skip the 200 x 200 mm layer and the K sweep")
    ap.add_argument("--speed-only", action="store_true", help="only the compile and per-layer times")
    ap.add_argument("--no-compile", action="store_true", help="skip the cold compile (about a minute of CPU)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    print("Compiled kernels (numba)")
    if not args.no_compile:
        compile_times()

    print("spacing: var_next = distance to the following path (the paper's), var_near = nearest other path;")
    print("coverage/overlap with beads of each path's local pitch (flow width); x = crossing pairs;")
    print("ms cold/warm: CPU time of one core (process time; the machine is shared, wall time is longer),")
    print("field raster built in the call / reused (median of the repeats).\n")
    region, field, load, t_fea = fea_case("ohs", specimen_region(), OHS_CASE, 2.0, scale_percentile=100.0)
    print(
        f"Open-hole specimen, real FEA field ({t_fea:.2f} s mesh + solve; mass scale {field.scale:.1f} MPa"
        f" = max |s| away from supports/loads), load entry {load};\nl = 0.4 mm (paper Table 1 in brackets;"
        " paper 198 ms)"
    )
    speed(args, EngineInput(region=region, field=field, pitch=PITCH, load_entry=load))
    if args.speed_only:
        return 0
    fea_runs = table1(args, "fea", region, field, load)
    reg2, f2, ld2, _ = fea_case("ohs", specimen_region(), None, 2.0, 100.0, REPO / "examples" / "ohs.toml")
    tp, cold, warm = timed(EngineInput(region=reg2, field=f2, pitch=PITCH, load_entry=ld2), 5.0, args.repeats)
    print(fmt_row("ohs.toml K=5", M.evaluate(tp, reg2, f2, PITCH), (cold, warm), PAPER[5.0]))
    print(f"  (examples/ohs.toml: its material, pull within 1 mm of the end; {tp.stats['swarms']} swarms)")
    print("\nOpen-hole specimen, Kirsch closed-form field")
    table1(args, "kirsch", *kirsch_specimen())

    if not args.quick:
        floor(region, field, load)
        print("\nBeyond the paper (target beta >= 0.993 with var_next <= 6e-3), FEA field:")
        print(HEADER)
        inp = EngineInput(region=region, field=field, pitch=PITCH, load_entry=load)
        tight = {"kill_below": 0.9, "spawn_above": 1.2}
        for name, K, kw in (
            ("K=0.2", 0.2, {}),
            ("K=1", 1.0, {}),
            ("K=2", 2.0, {}),
            ("K=5 0.9/1.2", 5.0, tight),
            ("K=5 w8 0.9/1.2", 5.0, {**tight, "window": 8}),
            ("K=20 w4", 20.0, {"window": 4, "kill_below": 0.9, "spawn_above": 1.15}),
        ):
            tp, cold, warm = timed(inp, K, 1, **kw)
            print(fmt_row(name, M.evaluate(tp, region, field, PITCH), (cold, warm)))
        big_region = box(0, 0, 200, 200).difference(
            shapely.union_all([Point(50, 60).buffer(8), Point(120, 140).buffer(12), Point(150, 50).buffer(6)])
        )
        breg, bfield, bload, bt = fea_case("plate", big_region, PLATE_CASE, 2.0)
        tp, cold, warm = timed(EngineInput(region=breg, field=bfield, pitch=PITCH, load_entry=bload), 5.0, 2)
        cov = M.coverage(tp, breg)
        print(
            f"\n200 x 200 mm layer, three holes, tension along x (real FEA, {bt:.1f} s), l = 0.4 mm, K = 5: "
            f"{cold:.2f} s cold, {warm:.2f} s warm, {tp.stats['steps']} steps, {tp.stats['swarms']} swarms, "
            f"{len(tp.paths)} paths, coverage {cov.coverage * 100:.2f} %, overlap {cov.overlap * 100:.2f} %"
        )

    print("\nOther regions (K = 5; uniform analytic fields, and the L-bracket with a real bearing-load FEA)")
    print(HEADER)
    cases = {
        "two islands": (
            MultiPolygon([box(0, 0, 20, 10), Point(35, 5).buffer(6)]),
            uniform(0),
            LineString([(0, 0), (0, 10)]),
        ),
        "concave": (
            Polygon([(0, 0), (30, 0), (30, 30), (20, 30), (20, 10), (10, 10), (10, 30), (0, 30)]),
            uniform(90),
            None,
        ),
        "several holes": (
            box(0, 0, 40, 30).difference(
                shapely.union_all(
                    [Point(10, 10).buffer(3), Point(28, 18).buffer(4), Point(15, 23).buffer(2.5)]
                )
            ),
            uniform(0),
            LineString([(0, 0), (0, 30)]),
        ),
    }
    for name, (reg, func, ld) in cases.items():
        f = AnalyticField(func, reg, scale=1.0)
        tp, cold, warm = timed(EngineInput(region=reg, field=f, pitch=PITCH, load_entry=ld), 5.0, 1)
        print(fmt_row(name, M.evaluate(tp, reg, f, PITCH), (cold, warm)))
    bracket = Polygon([(0, 0), (60, 0), (60, 15), (15, 15), (15, 40), (0, 40)]).difference(
        Point(52.5, 7.5).buffer(2.5, quad_segs=32)
    )
    reg, f, ld, _ = fea_case("bracket", bracket, BRACKET_CASE, 3.0)
    tp, cold, warm = timed(EngineInput(region=reg, field=f, pitch=PITCH, load_entry=ld), 5.0, 1)
    print(fmt_row("L-bracket bolt", M.evaluate(tp, reg, f, PITCH), (cold, warm)))
    print(fmt_row("  slicer best", M.baselines(reg, f, PITCH)["best"]))
    plot_paths(args.out, tp, reg, "bracket_paths.png")
    plot_paths(args.out, fea_runs[5.0], specimen_region(), "specimen_fea_k5.png")
    print(f"wall/CPU time ratio over all timed runs: {sum(WALL) / max(1e-9, sum(CPU)):.2f} (machine load)")
    print(f"plots: {args.out}/fig6_paths_*.png, fig7_spacing_*.png, fig8_specimen_*.png, bracket_paths.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
