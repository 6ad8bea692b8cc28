"""Streamline engine benchmark: the thesis's Table 4.2 cases, default and faithful mode.

Usage::

    python benchmarks/bench_streamlines.py PNG_DIR [--repeats 5] [--skip-faithful]

The thesis (Murugan, Ch. 4) gives the geometry of its three cases only in figures; they are rebuilt
here from their descriptions (``../shared/docs/benchmarks.md`` §2), all 2 mm thick plates, PLA,
solved by the in-house FEA (``loadpath.fea``, plane stress, quadratic triangles):

* A - open-hole plate in tension: 100 x 30 mm, one 10 mm hole at the centre, clamped at x_min,
  1000 N along +x at x_max (infill area 2921 mm²);
* B - plate in bending: 100 x 50 mm cantilever (the thesis's case B has A_in ~ 5000 mm²), clamped at
  x_min, 500 N along -y at x_max;
* C - five-hole plate in tension: 140 x 40 mm, five 8 mm holes in a zig-zag at x = 30, 50, 70, 90,
  110 mm (y = 20, 12, 20, 28, 20), clamped at x_min, 1000 N along +x at x_max.

Rows: the default mode on the followed stress of the product default (``max_abs``) and on the
thesis's field (tensile S1), the faithful mode (Table 4.1 parameters, S1, seeds at 0.2 per mm²), and
Table 4.2's figures.  Columns: coverage of the continuous filaments only (A_cf) and with gap filling
(A_f), overlap, both with beads of the flow width (each vertex's local pitch; faithful: the
thesis's constant w = 0.5 mm), number of filaments, share of discontinuous ones (``kind == "fill"``),
mean filament length, smallest centre-line distance (exact, segment to segment), crossings, and the
time per layer: median CPU time of ``--repeats`` runs on one core (BLAS threads pinned to 1), with
the wall time and the time of the slicer's rectilinear infill on the same layer (``metrics.rectilinear``)
measured in the same run as a reference.  The faithful mode is timed once (it is exempt from the
time target; the thesis took 18-51 min in MATLAB).  Then alignment: beta (Eq. 14) overall and where
the field curves, against the slicer's best rectilinear orientation (every 5 degrees).  PNGs of the
paths (continuous blue, gap filling red) go to PNG_DIR.
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
from loadpath.engines.streamlines import generate, resolve_params  # noqa: E402
from loadpath.engines.streamlines._lines import Lines, segment_distance  # noqa: E402
from loadpath.fea import analyze  # noqa: E402
from loadpath.loadcase import Body, from_dict, resolve_body  # noqa: E402
from loadpath.toolpath import EngineInput  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402
from shapely.geometry import Point, box  # noqa: E402

PITCH = 0.45  # the thesis's w + G_p; also a typical slicer solid-infill pitch for a 0.4 mm nozzle
THESIS = {  # Table 4.2: A_f (%), T_f (min)
    "A": (87, 30),
    "B": (89, 18),
    "C": (90, 51),
}
CLAMP = {"name": "clamp", "where": {"side": "x_min", "within": 0.5}, "fix": ["x", "y", "z"]}


def cases() -> dict[str, tuple[str, shapely.Geometry, list, list]]:
    pull = [{"name": "pull", "where": {"side": "x_max", "within": 0.5}, "force": [1000.0, 0.0, 0.0]}]
    tip = [{"name": "tip", "where": {"side": "x_max", "within": 0.5}, "force": [0.0, -500.0, 0.0]}]
    a = box(0, 0, 100, 30).difference(Point(50, 15).buffer(5, quad_segs=32))
    b = box(0, 0, 100, 50)
    holes = [(30, 20), (50, 12), (70, 20), (90, 28), (110, 20)]
    c = box(0, 0, 140, 40).difference(shapely.union_all([Point(h).buffer(4, quad_segs=32) for h in holes]))
    return {
        "A": ("open-hole plate, tension", a, [CLAMP], pull),
        "B": ("cantilever plate, bending", b, [CLAMP], tip),
        "C": ("five-hole plate, tension", c, [CLAMP], pull),
    }


def fea_field(region, supports, loads, principal):
    body = Body.from_layers("plate", [(0.0, 2.0, region)])
    rb = resolve_body(from_dict({"version": 1, "supports": supports, "loads": loads}), body)
    a = analyze(rb, pitch=PITCH)
    return a.field(z=1.0, principal=principal), a


def exact_min_spacing(paths) -> float:
    lines = Lines.from_list([p.points for p in paths])
    start, owner = lines.segments()
    a, b = lines.points[start], lines.points[start + 1]
    hmax = float(np.max(np.linalg.norm(b - a, axis=1)))
    pairs = cKDTree(0.5 * (a + b)).query_pairs(1.0 + hmax, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    m = owner[i] != owner[j]
    return float(np.min(segment_distance(a[i[m]], b[i[m]], a[j[m]], b[j[m]])))


def timed(inp, mode, repeats):
    cpu, wall = [], []
    tp = None
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        tp = generate(inp, mode=mode)
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - t0)
    return tp, statistics.median(cpu), statistics.median(wall)


def reference_time(region, repeats):
    ts = []
    for _ in range(repeats):
        c0 = time.process_time()
        M.rectilinear(region, PITCH, 0.0)
        ts.append(time.process_time() - c0)
    return statistics.median(ts)


def row(name, tp, region, cpu, wall, ref):
    cont = [p for p in tp.paths if p.kind == "continuous"]
    cov = M.coverage(tp, region)
    cc = M.coverage(cont, region) if cont else None
    lengths = [p.length for p in tp.paths]
    n = len(tp.paths)
    return {
        "name": name,
        "A_cf": 100 * (cc.coverage if cc else 0.0),
        "A_f": 100 * cov.coverage,
        "overlap": 100 * cov.overlap,
        "n": n,
        "disc": 100 * tp.stats["n_fill"] / max(n, 1),
        "mean_len": float(np.mean(lengths)) if lengths else 0.0,
        "dmin": exact_min_spacing(tp.paths) if n > 1 else float("nan"),
        "cross": M.crossings(tp),
        "cpu": cpu,
        "wall": wall,
        "ref": ref,
    }


def print_table(rows):
    head = (
        f"{'':34s} {'A_cf %':>7s} {'A_f %':>7s} {'ovl %':>6s} {'n':>5s} {'disc %':>7s} "
        f"{'mean mm':>8s} {'dmin mm':>8s} {'cross':>5s} {'CPU s':>8s} {'wall s':>7s} {'CPU/rect':>8s}"
    )
    print(head)
    for r in rows:
        if r.get("thesis"):
            print(f"{r['name']:34s} {'':>7s} {r['A_f']:7.0f} {'':>6s} {'':>5s} {'':>7s} {'':>8s} "
                  f"{'':>8s} {'':>5s} {r['cpu']:8.0f}  (MATLAB, min converted to s)")
            continue
        print(
            f"{r['name']:34s} {r['A_cf']:7.1f} {r['A_f']:7.1f} {r['overlap']:6.2f} {r['n']:5d} "
            f"{r['disc']:7.1f} "
            f"{r['mean_len']:8.1f} {r['dmin']:8.3f} {r['cross']:5d} {r['cpu']:8.3f} {r['wall']:7.3f} "
            f"{r['cpu'] / r['ref']:8.1f}"
        )


def plot(tp, region, title, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x0, y0, x1, y1 = region.bounds
    fig, ax = plt.subplots(figsize=(12, 12 * (y1 - y0) / (x1 - x0) + 0.8))
    for g in shapely.get_parts(region):
        ax.plot(*g.exterior.xy, "k-", lw=0.6)
        for r in g.interiors:
            ax.plot(*r.xy, "k-", lw=0.6)
    for p in tp.paths:
        colour = "tab:blue" if p.kind == "continuous" else "tab:red"
        ax.plot(p.points[:, 0], p.points[:, 1], "-", lw=0.5, color=colour)
    ax.set_aspect("equal")
    ax.set_title(f"{title}: continuous (blue), gap filling (red)")
    fig.savefig(path, dpi=150, bbox_inches="tight")
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("png_dir", type=Path)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--skip-faithful", action="store_true")
    args = ap.parse_args()
    args.png_dir.mkdir(parents=True, exist_ok=True)
    params = resolve_params("default", PITCH)
    print(
        f"pitch {PITCH} mm; default mode: step {params.step:.2f} mm RK2, "
        f"min spacing {params.min_spacing:.3f} mm, "
        f"bead width {params.width_min:.2f}-{params.width_max:.2f} mm (0.6-1.6 x 0.4 mm nozzle), "
        f"min length {params.min_length:.2f} mm, max turn {params.max_turn_deg:.0f} deg"
    )
    print("field: in-house FEA (loadpath.fea), plane stress, PLA, 2 mm plates\n")
    align_rows = []
    for key, (title, region, sup, loads) in cases().items():
        f_max, ana = fea_field(region, sup, loads, "max_abs")
        f_s1 = f_max.with_principal("tensile")
        print(f"== case {key}: {title}, infill area {region.area:.0f} mm², FEA {len(ana.mesh.points)} nodes")
        ref = reference_time(region, args.repeats)
        rows = []
        inp = EngineInput(region=region, field=f_max, pitch=PITCH)
        generate(inp)  # warm-up (imports, caches)
        tp, cpu, wall = timed(inp, "default", args.repeats)
        rows.append(row("default, max_abs (product default)", tp, region, cpu, wall, ref))
        plot(tp, region, f"case {key} default (max_abs)", args.png_dir / f"streamlines_{key}_default.png")
        al = M.alignment(tp, f_max, PITCH, region=region)
        best_ang, best = M.best_rectilinear(region, f_max, PITCH)
        align_rows.append((key, "max_abs", al, best_ang, best))
        inp1 = EngineInput(region=region, field=f_s1, pitch=PITCH)
        tp1, cpu1, wall1 = timed(inp1, "default", args.repeats)
        rows.append(row("default, tensile S1 (thesis field)", tp1, region, cpu1, wall1, ref))
        plot(tp1, region, f"case {key} default (S1)", args.png_dir / f"streamlines_{key}_default_s1.png")
        al1 = M.alignment(tp1, f_s1, PITCH, region=region)
        best_ang1, best1 = M.best_rectilinear(region, f_s1, PITCH)
        align_rows.append((key, "tensile", al1, best_ang1, best1))
        if not args.skip_faithful:
            tpf, cpuf, wallf = timed(inp1, "faithful", 1)
            rows.append(row("faithful (Table 4.1, S1)", tpf, region, cpuf, wallf, ref))
            plot(tpf, region, f"case {key} faithful", args.png_dir / f"streamlines_{key}_faithful.png")
        af, tf = THESIS[key]
        rows.append({"name": "thesis Table 4.2", "thesis": True, "A_f": af, "cpu": 60.0 * tf})
        print_table(rows)
        st = tp.stats["times_s"]
        print("   default stages (wall s, last run): " + ", ".join(f"{k} {v:.3f}" for k, v in st.items()))
        print()
    print("== alignment: beta (Eq. 14) of the default mode vs the slicer's best rectilinear orientation")
    print(f"{'case':5s} {'field':8s} {'beta':>7s} {'beta curved':>12s} {'curved share':>13s} "
          f"{'best rect deg':>13s} {'rect beta':>10s} {'rect curved':>12s}")
    for key, fld, al, ang, best in align_rows:
        print(f"{key:5s} {fld:8s} {al.beta:7.4f} {al.beta_curved:12.4f} {al.curved_weight:13.3f} "
              f"{ang:13.0f} {best.beta:10.4f} {best.beta_curved:12.4f}")


if __name__ == "__main__":
    main()
