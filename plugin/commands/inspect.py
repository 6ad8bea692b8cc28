"""Per-layer summary of a G-code file: z, height, feature types, islands, infill areas and kinds.

With --loadcase, also what each support and load selector picked on the part; with --png DIR,
pictures of each distinct layer (perimeters, part outline, infill domain, replace regions) and, with a
load case, of the selections and of the principal stress field of each distinct layer.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

HELP = "per-layer summary of a G-code file (regions, islands, infill kinds); optional pictures"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Register the command's arguments."""
    parser.add_argument("gcode", metavar="FILE.gcode",
                        help="G-code from PrusaSlicer (or a descendant) or Cura")
    parser.add_argument("--loadcase", metavar="CASE.toml", help="also resolve this load case on the part")
    parser.add_argument("--png", metavar="DIR", help="write pictures of each distinct layer into DIR")
    parser.add_argument("--replace", metavar="KINDS",
                        help="kinds whose replace region is shown, comma-separated (solid, sparse, top, "
                             "bottom); default: the load case's [toolpath] replace, else solid")


def run(args: argparse.Namespace) -> int:
    """Print the table (and draw the pictures)."""
    from loadpath import gcode, geometry
    from loadpath.errors import SettingsError
    from loadpath.geometry.summary import (
        describe_resolved,
        distinct_file_layers,
        format_layer_table,
        layer_rows,
    )

    lc = None
    if args.loadcase:
        from loadpath import loadcase

        lc = loadcase.read(args.loadcase)
    if args.replace:
        kinds = tuple(k.strip() for k in args.replace.split(",") if k.strip())
    elif lc is not None and lc.toolpath.replace:
        kinds = tuple(lc.toolpath.replace)
    else:
        kinds = geometry.DEFAULT_REPLACE
    bad = [k for k in kinds if k not in geometry.REPLACEABLE]
    if bad:
        raise SettingsError(f"--replace {','.join(bad)}: unknown kind; "
                            f"use any of {', '.join(geometry.REPLACEABLE)}")
    program = gcode.read(args.gcode)  # a missing/unreadable path is a one-line GCodeParseError
    # Blocks whose own lines leave the region derived for them are reported, not fatal: `run` keeps
    # them as sliced (loadpath.pipeline.units.unreliable_blocks), so inspect shows the same verdict.
    geo = geometry.layer_geometry(program, check=False)

    objs = ", ".join(f"{o.name!r} ({len(o.layers)} layers)" for o in geo.objects) or "none"
    print(f"{args.gcode}: {program.dialect.name}, {len(program.layers)} layers (counted from 1), "
          f"objects: {objs}")
    print(format_layer_table(layer_rows(program, geo, kinds), kinds))
    _print_unreliable(program, geo)

    resolved = ()
    if lc is not None:
        from loadpath import loadcase

        resolved = loadcase.resolve(lc, geo.bodies())
        print(f"load case {args.loadcase}:")
        for rb in resolved:
            print("\n".join(describe_resolved(rb)))

    if args.png:
        written = _draw(Path(args.png), program, geo, kinds, resolved, distinct_file_layers(geo, kinds))
        print(f"wrote {len(written)} picture(s) to {args.png}")
    return 0


def _draw(out: Path, program: Any, geo: Any, kinds: tuple[str, ...], resolved: Any,
          groups: dict[int, int]) -> list[Path]:
    """Pictures of each distinct layer, the selections and the stress fields."""
    from loadpath.geometry import distinct_layers
    from loadpath.geometry.plots import draw_layer, draw_selections, draw_stress

    written = []
    seen: set[int] = set()
    for index, group in sorted(groups.items()):
        if group in seen:
            continue
        seen.add(group)
        members = [i for i, g in groups.items() if g == group]
        layer = program.layers[index]
        title = (f"layer {index + 1} (z = {layer.z:g} mm), like {len(members)} layer(s): "
                 f"{_ranges([i + 1 for i in members])}")
        written.append(draw_layer(out / f"layer_{index + 1:04d}.png", program, geo.at(index), kinds, title))
    for rb in resolved:
        from loadpath.fea import analyze

        safe = _safe(rb.name)
        written.append(draw_selections(out / f"selections_{safe}.png", rb))
        analysis = analyze(rb)
        obj = geo.object(rb.name)
        # 2D: one field for every layer; 3D: one per distinct part outline
        reps = [obj.layers[0]] if rb.analysis == "2d" else \
            [next(g for g in obj.layers if g.layer_index == grp.representative)
             for grp in distinct_layers(obj, key="outline")]
        for g in reps:
            z = g.z - g.height / 2
            field = analysis.field(z)
            which = "all layers" if rb.analysis == "2d" else f"layer {g.layer_index + 1} (z = {g.z:g} mm)"
            title = (f"{rb.name}: principal stress ({field.principal}), {which}; "
                     f"residual {analysis.result.residual:.1e}")
            name = out / f"stress_{safe}_{g.layer_index + 1:04d}.png"
            written.append(draw_stress(name, field, g.outline, title))
    return written


def _print_unreliable(program: Any, geo: Any) -> None:
    """One line per infill block whose own lines leave the region derived for it."""
    from loadpath.pipeline.units import unreliable_blocks, unreliable_reason

    for b, dist in sorted(unreliable_blocks(geo).items()):
        line = int(program.blocks["start"][b]) + 1
        layer = int(program.blocks["layer"][b]) + 1
        why = unreliable_reason(dist)
        print(f"note: layer {layer}, block at line {line}: `loadpath run` keeps it as sliced ({why})")


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def _ranges(ix: list[int]) -> str:
    """[1, 2, 3, 7] -> '1-3, 7'."""
    ix = sorted(ix)
    parts, start, prev = [], ix[0], ix[0]
    for i in ix[1:] + [None]:
        if i is not None and i == prev + 1:
            prev = i
            continue
        parts.append(f"{start}-{prev}" if prev > start else f"{start}")
        if i is not None:
            start = prev = i
    return ", ".join(parts)
