"""Printability of the new infill beside the slicer's own (issue 19): paths, retractions, travel, time.

Usage::

    python benchmarks/bench_printability.py [OUT_DIR] [--quick] [--engine swarm,streamlines]
                                            [--parts bar,beam,...] [--principal alternate]

Parts (this benchmark's own; the acceptance parts are kept elsewhere), 2 top / 2 bottom solid layers:

``bar``      tension bar 90 x 18 x 2.4 mm with a 5 mm hole, clamped at x_min, pulled at x_max;
``beam``     cantilever 80 x 12 x 2.4 mm, clamped at x_min, 200 N down at x_max;
``bracket``  L-bracket 50 x 36 x 2.4 mm, 12 mm legs, 5 mm bolt hole; clamped at y_max, 300 N down at x_max;
``islands``  two 36 x 16 x 2.4 mm plates 8 mm apart (one object, two islands), each clamped at y_min
             and pulled at y_max;
``gyroid``   the bar at 30 % gyroid, sparse infill replaced;
``taper``    cantilever 80 x 12 mm tapering from 3.6 mm tall at x_min to 1.2 mm at x_max (not
             prismatic: a solid strip under each layer's top skin, a 3D analysis), loaded as ``beam``.

Each part is sliced by the real PrusaSlicer 2.5 (MK3S presets: ``retract_before_travel = 1``,
``only_retract_when_crossing_perimeters = 0``) and CuraEngine 4.13 (``prusa_i3_mk3``, combing on by
default), at 100 % (``solid`` replaced) and 40 % (``sparse`` replaced); then ``loadpath`` runs on the
file (as ``loadpath run`` does, without the slicer's settings JSON for Cura) with each engine.

Counted in the replaced blocks and the moves that lead into them and out of them (the block's
span: entering travel, retraction and lift; then the way to the next extrusion:
:func:`loadpath.printability.block_windows`; before 2026-12-06 without the way out), for the
slicer's lines and loadpath's: path count, retractions, travel mm, firmware-style print time
(acceleration and jerk), and the filament (same mass: the splicer matches each block's volume);
then the travel of the whole file (``file travel``).  Ratios are loadpath / slicer; the
``vsPrusa`` column compares a Cura file's retractions with PrusaSlicer's for the same part and
density.  On the files whose solid infill is replaced (100 %), ``cov s->l``: the coverage of the
infill domain by the infill beads of every layer with a replaced block, the slicer's file and
loadpath's, pooled by domain area (:func:`_coverage`; issue 19's coverage target).  ``loadpath
compare``'s coverage, which earlier rounds reported, samples four layers of the part, the first and
the last among them, which these parts print as the slicer's skins.
The results go to ``OUT_DIR/bench_printability.json`` when a folder is given.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import trimesh

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
import slicing  # noqa: E402
from cases import BRACKET_TIP, TIP_BEND, side_case  # noqa: E402

T = 2.4  # part thickness, mm: 12 layers of 0.2 mm, 8 of them infill layers

# the load cases, written as tests/cases.py writes them (x, y, z held at one side, a force at another)
PULL = side_case((1000.0, 0.0, 0.0), held_within=8.0, loaded_within=8.0)
BEND = TIP_BEND
ACROSS = side_case((0.0, 1000.0, 0.0), held="y_min", held_within=3.0, loaded="y_max", loaded_within=3.0)
BRACKET = BRACKET_TIP


def _parts() -> dict[str, tuple[trimesh.Trimesh, str]]:
    beam = slicing._at_origin(trimesh.creation.box(extents=(80.0, 12.0, T)))
    return {
        "bar": (slicing.ohs_mesh(90.0, 18.0, T, 5.0), PULL),
        "beam": (beam, BEND),
        "bracket": (slicing.bracket_mesh((50.0, 36.0), 12.0, T, 5.0), BRACKET),
        "islands": (slicing.two_islands_mesh((36.0, 16.0), 8.0, T), ACROSS),
        "gyroid": (slicing.ohs_mesh(90.0, 18.0, T, 5.0), PULL),
        "taper": (slicing.taper_mesh(80.0, 12.0, 1.5 * T, 0.5 * T), BEND),
    }


def _slices(part: str) -> list[tuple[str, str, dict, str]]:
    """(slicer, density label, settings, replaced kind) of a part."""
    if part == "gyroid":
        return [
            (
                "prusa",
                "30% gyroid",
                {**slicing.PRUSA_MIXED, "fill_density": "30%", "fill_pattern": "gyroid"},
                "sparse",
            ),
            (
                "cura",
                "30% gyroid",
                {**slicing.CURA_MIXED, "infill_sparse_density": "30", "infill_line_distance": "2.667",
                 "infill_pattern": "gyroid"},
                "sparse",
            ),
        ]
    return [
        ("prusa", "100%", dict(slicing.PRUSA_SOLID), "solid"),
        ("prusa", "40%", {**slicing.PRUSA_MIXED, "fill_density": "40%"}, "sparse"),
        ("cura", "100%", dict(slicing.CURA_SOLID), "solid"),
        (
            "cura",
            "40%",
            {**slicing.CURA_MIXED, "infill_sparse_density": "40", "infill_line_distance": "2.0"},
            "sparse",
        ),
    ]


def _named(engine: str) -> dict:
    """``--engine default``: no engine named, the product's own choice per kind."""
    return {} if engine == "default" else {"engine": engine}


def _measure(gcode: Path, case: Path, out: Path, engine: str, kind: str, principal: str) -> dict:
    from loadpath.gcode import read
    from loadpath.plugin.job import JobRequest, run_job
    from loadpath.printability import block_windows, kinematics_from_config, measure, measure_lines

    t0 = time.perf_counter()
    res = run_job(
        JobRequest(
            gcode,
            case,
            output=out,
            cli={**_named(engine), "replace": (kind,), "principal": principal},
        )
    )
    secs = time.perf_counter() - t0
    pr = res.pipeline
    if pr is None or pr.splice is None:
        return {"error": res.error or "nothing replaced", "warnings": res.warnings}
    program = pr.program
    kin = kinematics_from_config(program.config)
    new = read(out) if out.exists() else pr.output
    old_ranges, new_ranges = block_windows(program, new, pr.splice)
    slicer = measure_lines(program, old_ranges, kin)
    ours = measure_lines(new, new_ranges, kin)
    check = pr.check.problems if pr.check else ["not checked"]
    cover = _coverage(program, new, pr.splice) if kind == "solid" else None
    return {
        "coverage": cover,
        "blocks": len(pr.splice.blocks),
        "slicer": slicer.as_dict(),
        "loadpath": ours.as_dict(),
        "file_travel_mm": {
            "slicer": measure(program.moves, kin).travel_mm,
            "loadpath": measure(new.moves, kin).travel_mm,
        },
        "check_problems": len(check),
        "seconds": secs,
        "warnings": len(res.warnings),
    }


def _coverage(program, output, splice) -> dict[str, float]:
    """Coverage of the infill domain by the infill beads on every layer with a replaced block.

    Each object's layer domain is read from the input (the output keeps its perimeters); the beads
    are each file's own infill extrusions, their width from their extrusion
    (:func:`loadpath.stiffness.compare.infill_paths`, :func:`loadpath.metrics.coverage`), pooled
    over the layers by domain area.
    """
    from loadpath import geometry, metrics
    from loadpath.stiffness.compare import infill_paths

    layers = {program.block(rep.block).layer for rep in splice.blocks}
    geo = geometry.layer_geometry(program, check=False)
    covered = {"slicer": 0.0, "loadpath": 0.0}
    area = 0.0
    for obj in geo.objects:
        for g in obj.layers:
            if g.layer_index not in layers or g.domain.is_empty:
                continue
            area += g.domain.area
            for who, prog in (("slicer", program), ("loadpath", output)):
                paths = infill_paths(prog, g.layer_index, obj.code, geo.filament_diameter)
                if paths:
                    covered[who] += metrics.coverage(paths, g.domain).coverage * g.domain.area
    return {k: v / area if area > 0 else float("nan") for k, v in covered.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default=None)
    ap.add_argument("--quick", action="store_true", help="bar and bracket only, swarm only")
    ap.add_argument("--engine", default="swarm,streamlines")
    ap.add_argument("--parts", default=None)
    ap.add_argument("--principal", default="max_abs")
    ap.add_argument("--slicers", default="prusa,cura", help="which slicers' files (prusa, cura)")
    ap.add_argument("--work", default=None, help="folder for the slices (kept, reused when present)")
    args, _ = ap.parse_known_args(argv)
    engines = ["swarm"] if args.quick else args.engine.split(",")
    parts = _parts()
    names = args.parts.split(",") if args.parts else (["bar", "bracket"] if args.quick else list(parts))
    work = Path(args.work or tempfile.mkdtemp(prefix="bench_printability_"))
    rows = []
    for name in names:
        mesh, case_text = parts[name]
        stl = slicing.write_stl(mesh, work / f"{name}.stl")
        case = work / f"{name}.toml"
        case.write_text(case_text, encoding="utf-8")
        for slicer, label, sets, kind in _slices(name):
            if slicer not in args.slicers.split(","):
                continue
            tag = f"{name}-{slicer}-{label.replace('%', '').replace(' ', '')}"
            g = work / f"{tag}.gcode"
            if not g.exists():
                (slicing.slice_prusa if slicer == "prusa" else slicing.slice_cura)(stl, g, **sets)
            for engine in engines:
                r = _measure(g, case, work / f"{tag}.{engine}.gcode", engine, kind, args.principal)
                r.update(part=name, tool=slicer, density=label, engine=engine)
                rows.append(r)
                print(_row(r), flush=True)
    prusa = {
        (r["part"], r["density"], r["engine"]): r for r in rows if r["tool"] == "prusa" and "slicer" in r
    }
    print()
    print(_header())
    for r in rows:
        ref = prusa.get((r["part"], r["density"], r["engine"]))
        print(_row(r, ref))
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        (Path(args.out) / "bench_printability.json").write_text(json.dumps(rows, indent=1), encoding="utf-8")
    return 0


def _header() -> str:
    return (
        f"{'part':8} {'slicer':6} {'dens':10} {'engine':11} {'paths s->l':>13} {'ratio':>6} "
        f"{'retr s->l':>13} {'ratio':>6} {'travel mm s->l':>17} {'ratio':>6} "
        f"{'time s s->l':>15} {'ratio':>6} "
        f"{'fil':>5} {'vsPrusa':>7} chk {'file travel s->l':>19} {'ratio':>6} {'cov s->l':>13}"
    )


def _row(r: dict, ref: dict | None = None) -> str:
    if "slicer" not in r:
        return f"{r['part']:8} {r['tool']:6} {r['density']:10} {r['engine']:11} ERROR {r.get('error')}"
    s, n = r["slicer"], r["loadpath"]
    ft = r.get("file_travel_mm", {"slicer": 0.0, "loadpath": 0.0})

    def q(a: float, b: float) -> str:
        return f"{b / a:6.2f}" if a else "   inf" if b else "     -"

    vs = ""
    if ref is not None and r["tool"] != "prusa":
        vs = q(ref["slicer"]["retractions"], n["retractions"])
    return (
        f"{r['part']:8} {r['tool']:6} {r['density']:10} {r['engine']:11} "
        f"{s['paths']:>6}->{n['paths']:<6} {q(s['paths'], n['paths'])} "
        f"{s['retractions']:>6}->{n['retractions']:<6} {q(s['retractions'], n['retractions'])} "
        f"{s['travel_mm']:>8.0f}->{n['travel_mm']:<8.0f} {q(s['travel_mm'], n['travel_mm'])} "
        f"{s['print_s']:>7.0f}->{n['print_s']:<7.0f} {q(s['print_s'], n['print_s'])} "
        f"{q(s['filament_mm'], n['filament_mm']):>5} {vs:>7} {r['check_problems']:>3} "
        f"{ft['slicer']:>9.0f}->{ft['loadpath']:<9.0f} {q(ft['slicer'], ft['loadpath'])} "
        + (f"{cov['slicer']:.4f}->{cov['loadpath']:.4f}" if (cov := r.get("coverage")) else f"{'-':>13}")
    )


if __name__ == "__main__":
    raise SystemExit(main())
