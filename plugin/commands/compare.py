"""Predicted stiffness of G-code files under one load case, relative to the first file.

Each file's own beads (perimeters, infill, gap fill ...) set the local filament direction and fill of
an orthotropic printed-plastic model, and the load case is solved with the in-house FEA (2D plane
stress for a one-prism part, 3D otherwise; see ``loadpath.stiffness``).  The table gives the
compliance (f.u, lower is stiffer), the peak displacement, the stiffness relative to the first file
(absolute and per mass), the stress alignment beta, the infill coverage, and the first-ply failure
load, safety factor and relative strength (absolute and per mass; ``loadpath.stiffness.strength``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

HELP = "predicted stiffness of G-code files under a load case, relative to the first"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Register the command's arguments."""
    parser.add_argument(
        "files",
        nargs="+",
        metavar="FILE.gcode",
        help="G-code files of the same part; the first is the reference",
    )
    parser.add_argument("--loadcase", required=True, metavar="CASE.toml", help="the load case (interface.md)")
    parser.add_argument("--json", metavar="FILE", help="also write the rows as a JSON list of objects")
    parser.add_argument(
        "--report",
        metavar="DIR",
        help="draw the orientation field and strain energy density per file into DIR",
    )
    parser.add_argument(
        "--material",
        choices=("pla", "petg", "abs"),
        default=None,
        help="material card (default: the file's filament type, else pla; sources in loadpath.stiffness.cards)",
    )
    parser.add_argument(
        "--fill-model",
        choices=("beads", "linear", "nmo"),
        default="beads",
        help="beads (default: fusion, bead ends and crossings measured from the beads), linear "
        "(every stiffness scaled by the fill) or the thesis's spacing-dependent nmo",
    )
    parser.add_argument(
        "--resolution",
        type=float,
        default=None,
        metavar="MM",
        help="sampling step of the beads (default 0.1 mm; coarser is faster and noisier)",
    )
    parser.add_argument(
        "--ceiling",
        action="store_true",
        help="also print the model's ceiling (every element filled along its principal stress)",
    )


def run(args: argparse.Namespace) -> int:
    """Print the comparison table; write the JSON and the pictures when asked."""
    from loadpath import loadcase, stiffness
    from loadpath.fea.orthotropic import BEADS, LINEAR, NMO
    from loadpath.stiffness.compare import CompareRow

    lc = loadcase.read(args.loadcase)
    opts = stiffness.StiffnessOptions(
        fill_model={"beads": BEADS, "linear": LINEAR, "nmo": NMO}[args.fill_model],
        resolution=args.resolution or stiffness.DEFAULT_RESOLUTION,
        card=args.material,
    )
    rows, results = stiffness.compare_files(args.files, lc, opts)
    if args.ceiling:
        tops = [stiffness.ceiling(p.analysis.resolved, opts, mesh=p.mesh) for p in results[0].predictions]
        c, m = sum(t.compliance for t in tops), sum(t.mass for t in tops)
        ref = results[0]
        rows.append(
            CompareRow(
                "(model ceiling)",
                c,
                max(t.peak_displacement for t in tops),
                ref.compliance / c,
                float("nan"),
                float("nan"),
                m,
                ref.compliance * ref.mass / (c * m),
            )
        )
    print(_table(rows))
    for r in rows[1:]:
        if r.file == "(model ceiling)":
            continue
        print(
            f"at equal mass ({r.file} scaled to {rows[0].file}'s {rows[0].mass:.2f} g): "
            f"{r.relative_specific_stiffness:.3f}x as stiff, {r.relative_failure_load_per_mass:.3f}x the failure load"
        )
    for r, res in zip(rows, results, strict=False):
        if r.failure_location is not None:
            x, y, z = r.failure_location
            print(f"{r.file}: first ply fails at ({x:.1f}, {y:.1f}, {z:.2f}) mm ({r.failure_mode})")
    cards = {(res.card.key, res.card_why) for res in results}
    analyses = ", ".join(sorted({p.analysis.resolved.analysis for r in results for p in r.predictions}))
    print(
        f"model: {opts.fill_model.kind} fill model ({_FILL_SOURCE[opts.fill_model.kind]}); "
        f"first-ply failure: Tsai-Wu on bead stresses averaged over "
        f"{results[0].failures[0].a0 if results[0].failures else float('nan'):.2f} mm (Whitney-Nuismer); "
        f"{analyses} analysis"
    )
    for key, why in sorted(cards):
        card = stiffness.cards.card(key)
        print(f"card {card.name} ({why}); sources: {card.citation()}")
    if args.json:
        _write_atomic(Path(args.json), json.dumps([r.as_dict() for r in rows], indent=2) + "\n")
    if args.report:
        from loadpath.stiffness.plots import draw_gain, draw_prediction

        n = 0
        for i, r in enumerate(results):
            for p in r.predictions:
                n += len(draw_prediction(p, args.report, f"{i + 1:02d}_{Path(r.file).stem}_{_safe(p.name)}"))
        base = results[0]
        for i, r in enumerate(results[1:], start=2):
            for pa, pb, fa, fb in zip(base.predictions, r.predictions, base.failures, r.failures, strict=False):
                if pa.mesh is not pb.mesh:
                    continue  # different outlines: no common mesh to compare on
                name = f"{i:02d}_gain_{Path(r.file).stem}_vs_{Path(base.file).stem}_{_safe(pb.name)}.png"
                draw_gain(pa, pb, fa.index, fb.index, Path(args.report) / name)
                n += 1
        print(f"wrote {n} picture(s) to {args.report}")
    return 0


_FILL_SOURCE = {
    "beads": "loadpath.stiffness.beads: neck fusion from bead spacing, Cox shear lag at bead ends, "
    "rigid-jointed crossings after Gibson & Ashby",
    "linear": "every stiffness scaled by the fill",
    "nmo": "Murugan's thesis §3.2",
}


def _safe(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name)


def _table(rows) -> str:  # type: ignore[no-untyped-def]
    head = (
        f"{'file':<32} {'compliance N mm':>16} {'peak disp mm':>13} {'rel. stiffness':>15} "
        f"{'per mass':>9} {'mass g':>8} {'beta':>7} {'coverage':>9} {'fail. load N':>13} "
        f"{'safety':>7} {'rel. strength':>13} {'per mass':>9}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        name = r.file if len(r.file) <= 32 else "..." + r.file[-29:]
        beta = "-" if r.beta != r.beta else f"{r.beta:.4f}"
        cov = "-" if r.coverage != r.coverage else f"{100 * r.coverage:.1f} %"
        def num(v: float, fmt: str) -> str:
            return "-" if v != v else format(v, fmt)

        lines.append(
            f"{name:<32} {r.compliance:>16.5g} {r.peak_displacement:>13.5g} {r.relative_stiffness:>15.4f} "
            f"{r.relative_specific_stiffness:>9.4f} {r.mass:>8.3f} {beta:>7} {cov:>9} "
            f"{num(r.failure_load, '.5g'):>13} {num(r.safety_factor, '.3f'):>7} "
            f"{num(r.relative_failure_load, '.4f'):>13} {num(r.relative_failure_load_per_mass, '.4f'):>9}"
        )
    return "\n".join(lines)


def _write_atomic(path: Path, text: str) -> None:
    """Write the JSON table with the shared temporary-file-and-rename writer (umask permissions, not 0600)."""
    from loadpath.plugin.job import write_atomic

    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, text.encode("utf-8"))
