"""Swarm engine benchmark: the paper's Section IV-A (Table 1, Fig. 6, Fig. 7) and the other test regions.

Usage::

    python benchmarks/bench_swarm.py OUT_DIR [--repeats 3] [--quick]

Prints, for one slice of the open-hole specimen (150 x 36 mm, 6 mm hole, tension along x,
l = 0.4 mm) and K = 0.5, 5, 50: beta (Eq. 14) overall and where the field curves, the spacing
variance (both definitions of loadpath.metrics), time per slice (median of the repeats, one core),
coverage and overlap (flow-width beads = local pitch), beside the paper's Table 1 and the slicer's own
rectilinear infill at the same pitch.  Then the time of a 200 x 200 mm layer with three holes, and
coverage / overlap / crossings on the other test regions.  PNGs (paths around the hole, spacing
histograms) go to OUT_DIR.

Stress field: Kirsch's closed form (infinite plate with a hole) restricted to the specimen, and
analytic fields for the other regions (a radial 1/r compression from the bolt hole stands in for the
bearing load of the L-bracket); see the printed header.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import shapely  # noqa: E402
from loadpath import metrics as M  # noqa: E402
from loadpath.engines.swarm import generate  # noqa: E402
from loadpath.field import AnalyticField, kirsch_tensor  # noqa: E402
from loadpath.toolpath import EngineInput  # noqa: E402
from shapely.geometry import LineString, MultiPolygon, Point, Polygon, box  # noqa: E402

PITCH = 0.4
PAPER = {0.5: (0.981, 6.1e-3), 5.0: (0.993, 12.9e-3), 50.0: (0.998, 16.4e-3)}
PAPER_TIME_S = 0.198


def specimen():
    region = box(0, 0, 150, 36).difference(Point(75, 18).buffer(3, quad_segs=64))
    field = AnalyticField(lambda p: kirsch_tensor(p, (75, 18), 3.0, 1.0), region, scale=3.0)
    return region, field, LineString([(0, 0), (0, 36)])


def uniform(angle_deg):
    a = np.deg2rad(angle_deg)
    c, s = np.cos(a), np.sin(a)
    return lambda p: np.tile([c * c, s * s, c * s], (len(p), 1))


def radial(center):
    def func(p):
        d = p - np.asarray(center)
        r = np.maximum(np.linalg.norm(d, axis=1), 0.5)
        c, s = d[:, 0] / r, d[:, 1] / r
        srr, stt = -1.0 / r, -0.2 / r
        return np.stack([srr * c * c + stt * s * s, srr * s * s + stt * c * c, (srr - stt) * s * c], 1)

    return func


def timed(inp, K, repeats):
    times, tp = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        tp = generate(inp, K=K)
        times.append(time.perf_counter() - t0)
    return tp, statistics.median(times)


def fmt_row(name, m, t=None, paper=None):
    r = m.row()
    pb, pv = paper if paper else (float("nan"), float("nan"))
    ts = f"{t * 1e3:8.0f}" if t is not None else "       -"
    return (
        f"{name:<16} {r['beta']:.4f} ({pb:.3f})  {r['beta_curved']:.4f}  {r['next_var'] * 1e3:6.2f} ({pv * 1e3:5.1f})"
        f"  {r['spacing_var'] * 1e3:6.2f}  {r['spacing_min']:.2f}  {ts}  {r['coverage'] * 100:6.2f}"
        f"  {r['overlap'] * 100:5.2f}  {int(r['crossings']):3d}  {int(r['n_paths']):4d}"
    )


HEADER = (
    f"{'paths':<16} {'beta (paper)':<15} {'beta_c':<7} {'var_next e-3 (paper)':<20} {'var_near':<7} "
    f"{'min':<5} {'ms':>8}  {'cov %':>6}  {'ovl %':>5}  {'x':>3}  {'n':>4}"
)


def plot(out: Path, runs, region):
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
    fig.suptitle("Swarm paths around the hole (paper Fig. 6)")
    fig.savefig(out / "fig6_paths.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 4))
    for K, tp in runs.items():
        v = M.spacing(tp, PITCH, "next").values
        ax.hist(v, bins=np.linspace(0.4, 1.6, 61), histtype="step", density=True, label=f"K = {K:g}")
    ax.set_xlabel("distance to the following path / l")
    ax.legend()
    ax.set_title("Distribution of distances (paper Fig. 7)")
    fig.savefig(out / "fig7_spacing.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(16, 4.5))
    for p in runs[5.0].paths:
        ax.plot(p.points[:, 0], p.points[:, 1], lw=0.4)
    ax.set_aspect("equal")
    ax.set_title("K = 5, whole specimen (paper Fig. 8)")
    fig.savefig(out / "fig8_specimen.png", dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="folder for the PNG plots")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="skip the 200 x 200 mm layer")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    print("Stress field: Kirsch closed form (infinite plate with a hole) on the 150 x 36 mm specimen;")
    print("spacing: var_next = distance to the following path (the paper's), var_near = nearest other path;")
    print("coverage/overlap with beads of each path's local pitch (flow width); x = crossing pairs.\n")
    region, field, load = specimen()
    inp = EngineInput(region=region, field=field, pitch=PITCH, load_entry=load)
    runs = {}
    print("Open-hole specimen, one slice, l = 0.4 mm (paper Table 1 in brackets; paper time 198 ms)")
    print(HEADER)
    for K in (0.5, 5.0, 50.0):
        tp, t = timed(inp, K, args.repeats)
        runs[K] = tp
        print(fmt_row(f"swarm K={K:g}", M.evaluate(tp, region, field, PITCH), t, PAPER[K]))
    for name, m in M.baselines(region, field, PITCH).items():
        print(fmt_row(f"slicer {name}", m))
    st = runs[5.0].stats
    print(
        f"\nK = 5 time split: first swarm {st['time_first_swarm_s'] * 1e3:.0f} ms, fill {st['time_fill_s'] * 1e3:.0f} ms;"
        f" {st['steps']} steps, {st['qp_solves']} banded QP solves ({st.get('qp_exact', 0)} exact,"
        f" {st['qp_solves'] - st.get('qp_exact', 0)} OSQP fallbacks), {st.get('kills', 0)} kills,"
        f" {st.get('spawns', 0)} spawns, {st.get('swarms', 0)} swarms"
    )
    plot(args.out, runs, region)
    print(f"plots: {args.out}/fig6_paths.png, fig7_spacing.png, fig8_specimen.png")

    if not args.quick:
        big = box(0, 0, 200, 200).difference(
            shapely.union_all([Point(50, 60).buffer(8), Point(120, 140).buffer(12), Point(150, 50).buffer(6)])
        )
        bf = AnalyticField(uniform(0.0), big)
        binp = EngineInput(region=big, field=bf, pitch=PITCH, load_entry=LineString([(0, 0), (0, 200)]))
        tp, t = timed(binp, 5.0, 1)
        cov = M.coverage(tp, big)
        print(
            f"\n200 x 200 mm layer, three holes, l = 0.4 mm, K = 5: {t:.1f} s, {len(tp.paths)} paths,"
            f" coverage {cov.coverage * 100:.2f} %, overlap {cov.overlap * 100:.2f} %"
        )

    cases = {
        "two islands": (MultiPolygon([box(0, 0, 20, 10), Point(35, 5).buffer(6)]), uniform(0), LineString([(0, 0), (0, 10)])),
        "concave": (Polygon([(0, 0), (30, 0), (30, 30), (20, 30), (20, 10), (10, 10), (10, 30), (0, 30)]), uniform(90), None),
        "several holes": (
            box(0, 0, 40, 30).difference(
                shapely.union_all([Point(10, 10).buffer(3), Point(28, 18).buffer(4), Point(15, 23).buffer(2.5)])
            ),
            uniform(0),
            LineString([(0, 0), (0, 30)]),
        ),
        "L-bracket bolt": (
            Polygon([(0, 0), (40, 0), (40, 12), (12, 12), (12, 40), (0, 40)]).difference(Point(6, 34).buffer(2.5)),
            radial((6, 34)),
            Point(6, 34).buffer(2.5).exterior,
        ),
    }
    print("\nOther regions (K = 5; analytic fields: uniform, radial 1/r bearing approximation for the L-bracket)")
    print(HEADER)
    for name, (reg, func, ld) in cases.items():
        f = AnalyticField(func, reg, scale=1.0)
        tp, t = timed(EngineInput(region=reg, field=f, pitch=PITCH, load_entry=ld), 5.0, 1)
        print(fmt_row(name, M.evaluate(tp, reg, f, PITCH), t))
        if name == "L-bracket bolt":
            best = M.baselines(reg, f, PITCH)["best"]
            print(fmt_row("  slicer best", best))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
