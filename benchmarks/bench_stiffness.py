"""Predicted stiffness benchmark: the swarm paper's Table 2 in simulation, and an L-bracket.

Usage::

    python benchmarks/bench_stiffness.py [OUT_DIR] [--quick] [--repeats 3] [--paths run|direct]
                                         [--case specimen|bracket] [--engine swarm|streamlines]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

Everything is real G-code: PrusaSlicer 2.5 (MK3S presets, ``tests/slicing.py``) slices the part at
100 % infill with 0.45 mm line spacing (solid/top/first-layer extrusion width
``0.45 + h (1 - pi / 4)``, one top and one bottom layer, all infill rectilinear):

- **cross-hatching**: rectilinear at 45 degrees, alternating 90 degrees per layer (the paper's baseline);
- **rectilinear at a fixed angle**: ``alignedrectilinear`` (every layer the same way) at 0, 15, ...,
  165 degrees; **aligned** is the one along the part's dominant stress (0 degrees on the specimen),
  **best** the stiffest of them (the best the slicer's own rectilinear can do);
- **loadpath**: ``loadpath run`` on the cross-hatching file (every layer's infill replaced:
  ``--replace solid,top,bottom``, ``--pitch 0.45``; perimeters kept) with the swarm engine at
  K = 0.5, 5, 50 and the streamline engine.  ``--paths direct`` (or a failing ``loadpath run``)
  instead puts the engines' paths into the deposits directly (same flow width = local pitch).

Each file goes through ``loadpath.stiffness.evaluate_file`` (what ``loadpath compare`` does): the
beads of every layer set the fill and filament direction of an orthotropic printed-PLA ply, the
plies stack into a plane-stress plate, the load case is solved.  Printed: compliance, relative
stiffness against cross-hatching (absolute and per mass), beta, coverage, the gain as a share of
the model's ceiling gain (every element fully filled along its principal stress), and where each
design loses against the ceiling (strain energy difference by zone, fill, gaps, misalignment).
Then the model's figures beside the paper's printed Table 2, the same designs under the
thesis's spacing-dependent NMO model and under a PLA whose shear modulus is calibrated to the
paper's own aligned/cross-hatching ratio, a convergence check (sampling step, mesh) and timing.

Cases (frame = "part", so the slicer's placement on the bed does not matter):

- specimen: 150 x 36 x 2 mm, 6 mm hole (ASTM D5766), pulled through its end faces with 1000 N,
  clamped at the other end face;
- bracket: L-bracket 60 x 40 x 3 mm, legs 15 mm, 5 mm bolt hole at (52.5, 7.5) loaded by a pin
  (bearing, 300 N towards -y), fixed at the end of the other leg (y = 40).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from loadpath import engines, gcode, geometry, loadcase, stiffness  # noqa: E402
from loadpath.fea import analyze  # noqa: E402
from loadpath.fea.orthotropic import LINEAR, NMO, PLA_PRINTED  # noqa: E402
from loadpath.fea.stress import cell_stress  # noqa: E402
from loadpath.stiffness.predict import material_matrices, solve_printed  # noqa: E402
from loadpath.toolpath import EngineInput  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
import slicing  # noqa: E402

SPACING = 0.45
LAYER = 0.2
WIDTH = SPACING + LAYER * (1.0 - math.pi / 4.0)  # PrusaSlicer's rounded bead: spacing = w - h (1 - pi/4)
KINDS = ("solid", "top", "bottom")
PAPER = {"cross-hatching": 17.48, "aligned": 19.53, "global [21]": 19.91, "swarm K=5": 21.73}

SPECIMEN_CASE = """
version = 1
frame = "part"
[[supports]]
name = "grip"
where = { x_max = 0.5 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { x_min = 149.5 }
force = [1000.0, 0.0, 0.0]
"""

BRACKET_CASE = """
version = 1
frame = "part"
[[supports]]
name = "wall"
where = { side = "y_max", within = 1.0 }
fix = ["x", "y", "z"]
[[loads]]
name = "bolt"
where = { hole_near = [52.5, 7.5], radius = 5.0 }
force = [0.0, -300.0, 0.0]
"""

CASES = {
    "specimen": {
        "part": "ohs",
        "case": SPECIMEN_CASE,
        "zones": {
            "support end": ("box", (0, 0, 15, 36)),
            "load end": ("box", (135, 0, 150, 36)),
            "hole": ("disc", (75, 18, 9.0)),
        },
    },
    "bracket": {
        "part": "bracket",
        "case": BRACKET_CASE,
        "zones": {
            "bolt hole": ("disc", (52.5, 7.5, 7.5)),
            "inner corner": ("disc", (15, 15, 8.0)),
            "wall end": ("box", (0, 32, 15, 40)),
        },
    },
}

PRUSA = {
    **slicing.PRUSA_SOLID,
    "top_solid_layers": "1",
    "bottom_solid_layers": "1",
    "solid_infill_extrusion_width": f"{WIDTH:.4f}",
    "infill_extrusion_width": f"{WIDTH:.4f}",
    "top_infill_extrusion_width": f"{WIDTH:.4f}",
    "first_layer_extrusion_width": f"{WIDTH:.4f}",
}


def slice_design(stl: Path, out: Path, pattern: str, angle: float) -> Path:
    if not out.exists():
        slicing.slice_prusa(
            stl,
            out,
            **{
                **PRUSA,
                "fill_pattern": pattern,
                "fill_angle": f"{angle:g}",
                "top_fill_pattern": pattern,
                "bottom_fill_pattern": pattern,
            },
        )
    return out


def layer_angles(path: Path) -> str:
    """The infill directions the slicer actually printed, per layer (for the record)."""
    geo = geometry.layer_geometry(gcode.read(path), check=False)
    angles = []
    for g in geo.objects[0].layers:
        a = sorted({round(b.angle) % 180 for b in g.blocks if b.kind in KINDS and np.isfinite(b.angle)})
        angles.append("/".join(str(x) for x in a) or "-")
    return " ".join(angles)


def loadpath_run(
    src: Path, case: Path, out: Path, engine: str, K: float | None, extra: list[str]
) -> tuple[bool, float, str]:
    """``loadpath run`` in a subprocess; returns (ok, seconds, message)."""
    if out.exists():
        return True, 0.0, "cached"
    cmd = [
        sys.executable,
        "-m",
        "loadpath.plugin.cli",
        "run",
        str(src),
        "--loadcase",
        str(case),
        "-o",
        str(out),
        "--engine",
        engine,
        "--replace",
        ",".join(KINDS),
        "--pitch",
        f"{SPACING}",
    ]
    if K is not None:
        cmd += ["--K", f"{K:g}"]
    cmd += extra
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    dt = time.perf_counter() - t
    return proc.returncode == 0 and out.exists(), dt, (proc.stderr.strip().splitlines() or [""])[-1]


def direct_deposits(program, lc, opts, meshes, engine: str, K: float | None):
    """The engine's paths put into the deposits directly (no splice): what ``run`` would print.

    The engine fills what ``loadpath run`` gives it: each unit's replace region grown by the
    slicer's own infill-perimeter overlap (:func:`loadpath.pipeline.units.with_overlap`).
    """
    from loadpath.pipeline.units import select_units, with_overlap

    geo = geometry.layer_geometry(program, check=False)
    (rb,) = loadcase.resolve(lc, geo.bodies())
    obj = geo.object(rb.name)
    mesh = stiffness.stiffness_mesh(rb, opts.pitch)
    iso = analyze(rb, mesh=mesh)
    cache, parts, excl = {}, [], []
    kw = {} if K is None else {"K": K}
    units = with_overlap(select_units(geo, [rb.name], KINDS, SPACING), program, geo)
    z_of = {g.layer_index: (g.z, g.height) for g in obj.layers}
    for u in units:
        region = u.fill_region
        excl += [b.block_index for b in u.blocks]
        z, h = z_of[u.layer]
        if region.wkb not in cache:
            field = iso.field(z - 0.5 * h)
            cache[region.wkb] = engines.generate(
                engine, EngineInput(region, field, SPACING, field.load_entry), **kw
            )
        parts.append(stiffness.from_toolpaths(cache[region.wkb], z, h, u.layer))
    kept = stiffness.from_program(program, obj.code, exclude_blocks=excl)
    return rb, stiffness.Deposits.concat([kept, *parts])


# ------------------------------------------------------------------------------------------ analysis


def zone_masks(pred, zones, origin):
    c = pred.mesh.points[pred.mesh.cells[:, : pred.mesh.n_corners]].mean(axis=1)[:, :2] - origin[:2]
    out, rest = {}, np.ones(len(c), dtype=bool)
    for name, (kind, p) in zones.items():
        if kind == "box":
            m = (c[:, 0] >= p[0]) & (c[:, 1] >= p[1]) & (c[:, 0] <= p[2]) & (c[:, 1] <= p[3])
        else:
            m = np.hypot(c[:, 0] - p[0], c[:, 1] - p[1]) <= p[2]
        m &= rest
        out[name] = m
        rest &= ~m
    out["rest"] = rest
    return out


def element_volume(mesh):
    return np.abs(mesh.measures) * (mesh.thickness if mesh.dim == 2 else 1.0)


def principal_angle(pred):
    mesh = pred.mesh
    s = cell_stress(mesh, pred.D, pred.analysis.result.u, np.full((1, mesh.dim), 1.0 / (mesh.dim + 1)))[:, 0]
    sxx, syy, sxy = (s[:, 0], s[:, 1], s[:, 2]) if mesh.dim == 2 else (s[:, 0], s[:, 1], s[:, 5])
    t = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    return np.where(sxx + syy >= 0, t, t + 0.5 * np.pi)


def diagnose(pred, top, zones, origin):
    """Per zone: share of the compliance gap to the ceiling, fill, gap area, misalignment."""
    vol = element_volume(pred.mesh)
    energy, energy_top = pred.energy_density * vol, top.energy_density * vol
    gap_total = pred.compliance - top.compliance
    eff = pred.fields.effective_fill() if pred.fields is not None else np.ones((1, len(vol)))
    w = pred.fields.weight if pred.fields is not None else np.ones(1)
    fill = np.einsum("l,lm->m", w, eff)
    area = np.abs(pred.mesh.measures)
    gaps = np.einsum("l,lm->m", w, (eff < 0.85).astype(float)) * area  # mm² of plies below 0.85 fill
    mis = np.abs(np.angle(np.exp(2j * (pred.angle - principal_angle(pred))))) / 2.0
    rows = []
    for name, m in zone_masks(pred, zones, origin).items():
        dc = 2.0 * float(np.sum(energy[m] - energy_top[m]))
        e = energy[m] * pred.strength[m]
        rows.append(
            (
                name,
                float(area[m].sum()),
                dc,
                dc / gap_total if gap_total else float("nan"),
                float(np.sum(fill[m] * vol[m]) / np.sum(vol[m])),
                float(gaps[m].sum()),
                float(np.degrees(np.sum(mis[m] * e) / max(np.sum(e), 1e-300))),
            )
        )
    return rows


def edge_fill(pred, rb) -> str:
    """Mean effective fill against the distance to the outline: the perimeter-infill junction."""
    import shapely

    mesh = pred.mesh
    c = mesh.points[mesh.cells[:, : mesh.n_corners]].mean(axis=1)[:, :2]
    outline = rb.body.slabs[len(rb.body.slabs) // 2].outline
    d = shapely.distance(outline.boundary, shapely.points(c))
    holes = [r for poly in getattr(outline, "geoms", [outline]) for r in poly.interiors]
    dh = shapely.distance(shapely.union_all(holes), shapely.points(c)) if holes else np.full(len(c), np.inf)
    eff = np.einsum("l,lm->m", pred.fields.weight, pred.fields.effective_fill())
    vol = element_volume(mesh)
    out = []
    for name, m in (
        ("< 1.5 mm from the outline", d < 1.5),
        ("1.5-3 mm", (d >= 1.5) & (d < 3.0)),
        ("> 3 mm", d >= 3.0),
        ("< 3 mm from a hole", dh < 3.0),
    ):
        if np.any(m):
            out.append(f"fill {name} {np.sum(eff[m] * vol[m]) / np.sum(vol[m]):.3f}")
    return ", ".join(out)


def revalue(pred, material, model):
    """The same beads under another material or fill model (same mesh, same sampling)."""
    rb = pred.analysis.resolved
    D = material_matrices(pred.fields, material, model, pred.mesh.dim)
    _, c, *_ = solve_printed(rb, pred.mesh, D)
    return c


def g12_for_ratio(ratio: float) -> float:
    """G12 at which the model's aligned/cross-hatching laminate ratio E_x(0) / E_x(+-45) equals ``ratio``."""
    from loadpath.fea.orthotropic import PrintedMaterial, rotate

    def r(g):
        m = PrintedMaterial("x", PLA_PRINTED.E1, PLA_PRINTED.E2, g, PLA_PRINTED.nu12)
        Q = m.plane_stress()
        lam = 0.5 * (rotate(Q, np.pi / 4)[0] + rotate(Q, -np.pi / 4)[0])
        return (1.0 / np.linalg.inv(Q)[0, 0]) / (1.0 / np.linalg.inv(lam)[0, 0])

    lo, hi = 10.0, PLA_PRINTED.G12
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if r(mid) > ratio else (lo, mid)
    return 0.5 * (lo + hi)


# ------------------------------------------------------------------------------------------ runs


def run_case(name, spec, work: Path, out: Path, args) -> dict:
    print(f"\n=== {name}: {spec['part']} ===")
    stl = slicing.write_stl(slicing.PARTS[spec["part"]](), work / f"{spec['part']}.stl")
    case_path = work / f"{name}.toml"
    case_path.write_text(spec["case"])
    lc = loadcase.read(case_path)
    opts = stiffness.StiffnessOptions(pitch=SPACING)
    meshes: dict = {}
    files = {"cross-hatching": slice_design(stl, work / f"{name}-cross.gcode", "rectilinear", 45.0)}
    angles = (0, 45, 90, 135) if args.quick else tuple(range(0, 180, 15))
    for a in angles:
        files[f"rect {a:3d}"] = slice_design(stl, work / f"{name}-rect{a}.gcode", "alignedrectilinear", a)
    print("slicer infill directions per layer (degrees):")
    for k, p in files.items():
        print(f"  {k:<15} {layer_angles(p)}")
    results, how = {}, {}
    t0 = time.perf_counter()
    for k, p in files.items():
        results[k] = stiffness.evaluate_file(p, lc, opts, meshes, name=k)
        how[k] = "PrusaSlicer 2.5"
    print(f"slicer files evaluated in {time.perf_counter() - t0:.1f} s")
    ref = results["cross-hatching"]
    rb = ref.predictions[0].analysis.resolved
    mesh = ref.predictions[0].mesh
    top = stiffness.ceiling(rb, opts, mesh)
    iso = ref.isotropic[0]
    from loadpath import metrics

    field = iso.field()
    dom = np.degrees(metrics.dominant_direction(field, metrics._grid(field.region, 0.5)))
    aligned_angle = min(angles, key=lambda a: abs(((a - dom + 90) % 180) - 90))
    rect = {k: v for k, v in results.items() if k.startswith("rect")}
    best_key = min(rect, key=lambda k: rect[k].compliance)
    print(
        f"dominant stress direction {dom:.1f} deg -> aligned = rect {aligned_angle}; "
        f"stiffest rectilinear: {best_key}"
    )

    # (label, engine, K, extra `loadpath run` options); the last two rows are diagnostics of the
    # splice: the same swarm paths without volume matching, and put into the deposits directly
    engines_run = [
        ("swarm K=0.5", "swarm", 0.5, []),
        ("swarm K=5", "swarm", 5.0, []),
        ("swarm K=50", "swarm", 50.0, []),
        ("streamlines", "streamlines", None, []),
        ("swarm K=5 noVM", "swarm", 5.0, ["--set", "match_volume=false"]),
        ("swarm K=5 direct", "swarm", 5.0, None),
    ]
    if args.quick:
        engines_run = [engines_run[1], engines_run[3], engines_run[5]]
    if args.engine:
        engines_run = [e for e in engines_run if e[1] in args.engine]
    for label, engine, K, extra in engines_run:
        tag = "-novm" if extra else ""
        dst = work / f"{name}-{engine}{'' if K is None else f'-K{K:g}'}{tag}.gcode"
        ok, dt, msg = (
            (False, 0.0, "paths put in directly")
            if args.paths == "direct" or extra is None
            else loadpath_run(files["cross-hatching"], case_path, dst, engine, K, extra)
        )
        if ok:
            results[label] = stiffness.evaluate_file(dst, lc, opts, meshes, name=label)
            files[label] = dst
            how[label] = f"loadpath run ({dt:.0f} s)" if dt else "loadpath run"
        else:
            if extra is not None:
                print(f"  {label}: loadpath run unavailable or failed ({msg}); paths put in directly")
            prog = gcode.read(files["cross-hatching"])
            rb_d, dep = direct_deposits(prog, lc, opts, meshes, engine, K)
            pred = stiffness.predict(rb_d, dep, opts, mesh)
            results[label] = stiffness.FileResult(label, (pred,), ref.isotropic, float("nan"), float("nan"))
            how[label] = "engine paths put in directly (flow width = local pitch, no splice)"

    # ------------------------------------------------------------ table
    print(
        f"\nceiling: compliance {top.compliance:.2f} N mm, mass {top.mass:.3f} g, "
        f"{len(top.info['history'])} alignment iterations {[f'{c:.2f}' for c in top.info['history']]}"
    )
    head = (
        f"{'design':<16} {'compliance':>10} {'rel.':>7} {'rel./mass':>9} {'mass g':>7} {'beta':>6} "
        f"{'cov %':>6}"
        f" {'share':>6} {'share/m':>7}  source"
    )
    print(head)
    print("-" * len(head))
    rows = {}
    for k, r in results.items():
        g = stiffness.gains(ref, r, top)
        rows[k] = g
        tag = " (aligned)" if k == f"rect {aligned_angle:3d}" else (" (best)" if k == best_key else "")
        print(
            f"{k + tag:<16} {r.compliance:>10.2f} {ref.compliance / r.compliance:>7.4f} "
            f"{ref.compliance * ref.mass / (r.compliance * r.mass):>9.4f} {r.mass:>7.3f} {r.beta:>6.3f} "
            f"{100 * r.coverage:>6.1f} {g['share']:>6.2f} {g['specific_share']:>7.2f}  {how[k]}"
        )
    print(
        f"{'ceiling':<16} {top.compliance:>10.2f} {ref.compliance / top.compliance:>7.4f} "
        f"{ref.compliance * ref.mass / (top.compliance * top.mass):>9.4f} {top.mass:>7.3f}"
    )

    aligned = results[f"rect {aligned_angle:3d}"]
    best = results[best_key]
    for label in ("swarm K=5", "swarm K=5 noVM", "swarm K=5 direct"):
        sw = results.get(label)
        if sw is None:
            continue
        g = rows[label]
        print(f"\ndone-when check ({label}{'' if label == 'swarm K=5' else ', diagnostic'}):")
        print(
            f"  share of the ceiling gain over cross-hatching: {g['share']:.2f} absolute, "
            f"{g['specific_share']:.2f} per mass (target >= 0.70) -> "
            f"{'PASS' if g['share'] >= 0.7 else 'MISS'} / {'PASS' if g['specific_share'] >= 0.7 else 'MISS'}"
        )
        for lbl, other in (("aligned rectilinear", aligned), ("best rectilinear", best)):
            ra, rm = (
                other.compliance / sw.compliance,
                other.compliance * other.mass / (sw.compliance * sw.mass),
            )
            print(
                f"  vs {lbl}: {ra:.4f} absolute, {rm:.4f} per mass -> "
                f"{'PASS' if ra > 1 else 'MISS'} / {'PASS' if rm > 1 else 'MISS'}"
            )

    # ------------------------------------------------------------ where the designs lose
    origin = rb.body.bounds[0]
    print(
        "\nwhere each design loses against the ceiling (dc: compliance above the ceiling's, N mm, by zone;"
        " fill: mean effective fill; gaps: mm² of plies below 0.85 fill; mis: energy-weighted angle"
        " between filament and principal stress, deg)"
    )
    for k in ("cross-hatching", f"rect {aligned_angle:3d}", *[e[0] for e in engines_run if e[0] in results]):
        p = results[k].predictions[0]
        parts = [
            f"{z}: dc {dc:6.2f} ({100 * sh:4.0f} %) fill {fl:.3f} gaps {gp:6.1f} mis {ms:4.1f}"
            for z, _, dc, sh, fl, gp, ms in diagnose(p, top, spec["zones"], origin)
        ]
        print(f"  {k:<16} " + " | ".join(parts))
        print(f"  {'':<16} " + edge_fill(p, rb))

    # ------------------------------------------------------------ pictures
    from loadpath.stiffness.plots import draw_energy, draw_orientation

    for k in ("cross-hatching", f"rect {aligned_angle:3d}", "swarm K=5", "streamlines"):
        if k in results:
            p = results[k].predictions[0]
            stem = k.replace(" ", "").replace("=", "")
            draw_orientation(
                p, out / f"{name}_{stem}_orientation.png", f"{name}, {k}: filament direction and fill"
            )
            draw_energy(p, out / f"{name}_{stem}_energy.png", f"{name}, {k}: strain energy density")
    draw_orientation(top, out / f"{name}_ceiling_orientation.png", f"{name}: model ceiling")
    return {
        "results": results,
        "top": top,
        "aligned": aligned_angle,
        "best": best_key,
        "rows": rows,
        "paths": files,
    }


def model_variants(name, data):
    """The same beads under NMO and under a PLA with the paper's own anisotropy."""
    res, top = data["results"], data["top"]
    ratio = PAPER["aligned"] / PAPER["cross-hatching"]
    g12 = g12_for_ratio(ratio)
    cal = replace(PLA_PRINTED, name="PLA, G12 fitted to the paper's aligned/cross ratio", G12=g12)
    keys = ["cross-hatching", f"rect {data['aligned']:3d}", data["best"], "swarm K=5", "streamlines"]
    keys = list(dict.fromkeys(k for k in keys if k in res))
    print(
        f"\n{name}: sensitivity to the material model (relative stiffness against cross-hatching, absolute)"
    )
    print(
        f"  fitted G12 = {g12:.0f} MPa (default {PLA_PRINTED.G12:.0f}) makes E_x(0)/E_x(+-45) = {ratio:.3f}"
    )
    for label, mat, model in (
        ("PLA linear", PLA_PRINTED, LINEAR),
        ("PLA NMO (thesis)", PLA_PRINTED, NMO),
        ("PLA G12 fitted", cal, LINEAR),
    ):
        c = {k: revalue(res[k].predictions[0], mat, model) for k in keys}
        t = stiffness.ceiling(
            top.analysis.resolved, stiffness.StiffnessOptions(material=mat, fill_model=model), top.mesh
        ).compliance
        base = c["cross-hatching"]
        cells = "  ".join(f"{k.strip()} {base / v:.4f}" for k, v in c.items())
        sw = c.get("swarm K=5")
        share = (base / sw - 1) / (base / t - 1) if sw else float("nan")
        print(f"  {label:<22} {cells}  ceiling {base / t:.4f}  swarm share {share:.2f}")


def convergence(data):
    """Sampling step and mesh size: how much the relative stiffness moves."""
    from loadpath.mesh.sizing import MeshSize

    res, paths = data["results"], data["paths"]
    ref = res["cross-hatching"].predictions[0]
    rb = ref.analysis.resolved
    keys = [k for k in ("swarm K=5", "streamlines", f"rect {data['aligned']:3d}") if k in paths]
    print("\nconvergence (specimen): relative stiffness against cross-hatching")
    fine = stiffness.stiffness_mesh(rb, SPACING, MeshSize(1.5, 0.6, 0.6))
    for label, opts, mesh in (
        ("step 0.1 mm, default mesh", stiffness.StiffnessOptions(pitch=SPACING), ref.mesh),
        ("step 0.05 mm, default mesh", stiffness.StiffnessOptions(pitch=SPACING, resolution=0.05), ref.mesh),
        ("step 0.1 mm, finer mesh", stiffness.StiffnessOptions(pitch=SPACING), fine),
    ):
        cs = {}
        for k in ["cross-hatching", *keys]:
            prog = gcode.read(paths[k])
            code = geometry.layer_geometry(prog, check=False).objects[0].code
            cs[k] = stiffness.predict(rb, stiffness.from_program(prog, code), opts, mesh).compliance
        top = stiffness.ceiling(rb, opts, mesh).compliance
        base = cs["cross-hatching"]
        print(
            f"  {label:<27} "
            + "  ".join(f"{k} {base / v:.4f}" for k, v in cs.items() if k != "cross-hatching")
            + f"  ceiling {base / top:.4f}  ({len(mesh.cells)} elements)"
        )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "out", nargs="?", default=None, help="folder for the pictures and G-code (default: a temp dir)"
    )
    ap.add_argument("--quick", action="store_true", help="4 slicer angles, swarm K=5 and streamlines only")
    ap.add_argument("--repeats", type=int, default=3, help="timing repeats")
    ap.add_argument(
        "--paths",
        choices=("run", "direct"),
        default="run",
        help="loadpath's output from `loadpath run` (default) or the engines' paths put in directly",
    )
    ap.add_argument("--case", choices=tuple(CASES), action="append", help="run only this case (repeatable)")
    ap.add_argument(
        "--engine",
        choices=engines.NAMES,
        action="append",
        help="run only this engine's loadpath rows (repeatable; the slicer's designs always run)",
    )
    args, _ = ap.parse_known_args(argv)
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_stiffness_"))
    out.mkdir(parents=True, exist_ok=True)
    work = out / "gcode"
    work.mkdir(exist_ok=True)
    print(
        f"{slicing.prusa_version()}; model {PLA_PRINTED.name}: E1 {PLA_PRINTED.E1:g}, E2 {PLA_PRINTED.E2:g}, "
        f"G12 {PLA_PRINTED.G12:g} MPa, nu12 {PLA_PRINTED.nu12:g} ({PLA_PRINTED.source})"
    )
    print(
        f"spacing {SPACING} mm (bead width {WIDTH:.4f} mm at {LAYER} mm layers), 100 % infill; "
        f"output in {out}"
    )
    data = {}
    for name, spec in CASES.items():
        if args.case and name not in args.case:
            continue
        data[name] = run_case(name, spec, work, out, args)
        model_variants(name, data[name])
    if "specimen" not in data:
        return 0

    spec = data["specimen"]
    res, ref = spec["results"], spec["results"]["cross-hatching"]
    print(
        "\npaper Table 2 (printed, specific modulus) beside the model "
        "(specimen, per mass, against cross-hatching):"
    )
    model_rows = {
        "cross-hatching": ref,
        "aligned": res[f"rect {spec['aligned']:3d}"],
        "swarm K=5": res.get("swarm K=5"),
    }
    for k, paper in PAPER.items():
        r = model_rows.get(k)
        mod = "-" if r is None else f"{ref.compliance * ref.mass / (r.compliance * r.mass):.4f}"
        print(f"  {k:<16} paper {paper:6.2f} ({paper / PAPER['cross-hatching']:.3f})   model {mod}")

    if not args.quick:
        convergence(spec)

    # ------------------------------------------------------------ timing (median of repeats)
    lc = loadcase.read(work / "specimen.toml")
    f = work / "specimen-cross.gcode"
    meshes: dict = {}
    stiffness.evaluate_file(f, lc, stiffness.StiffnessOptions(pitch=SPACING), meshes)  # warm the mesh cache
    t_eval, t_iso = [], []
    for _ in range(max(1, args.repeats)):
        t = time.perf_counter()
        r = stiffness.evaluate_file(f, lc, stiffness.StiffnessOptions(pitch=SPACING), meshes)
        t_eval.append(time.perf_counter() - t)
        rb = r.predictions[0].analysis.resolved
        t = time.perf_counter()
        analyze(rb, mesh=r.predictions[0].mesh)
        t_iso.append(time.perf_counter() - t)
    me, mi = statistics.median(t_eval), statistics.median(t_iso)
    print(
        f"\ntiming (specimen, cross-hatching file, median of {len(t_eval)}): evaluate_file {me:.2f} s "
        f"= {me / mi:.1f} x the isotropic FEA solve on the same mesh ({mi:.3f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
