"""Layer geometry benchmark: time to derive outlines, domains and block regions from real G-code.

Usage::

    python benchmarks/bench_geometry.py [OUT_DIR] [--repeats 5] [--quick]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

Inputs are real: PrusaSlicer 2.5 and CuraEngine 4.13 slice test parts (``tests/slicing.py``): the
24 mm twisted tower (120 layers, every layer a different outline) and the open-hole specimen
(10 layers), 20 % sparse infill and 100 % infill.  Medians of the repeats, one process:

- ``parse``: ``loadpath.gcode.read`` (the reference every other figure is divided by);
- ``geometry``: ``loadpath.geometry.layer_geometry`` (walls, islands, blocks, pitch, footprints,
  regions, kinds, region check), total and per layer;
- ``walls only`` vs ``naive walls``: the perimeter bands of every layer built as loadpath does
  (chains of segments joined with numpy, one ``shapely.buffer`` call with per-chain widths) and the
  straightforward way (every segment buffered on its own, then ``union_all``), same output.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import shapely
from loadpath import gcode, geometry
from loadpath.gcode import Role
from loadpath.geometry.ops import bead_union

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
import slicing  # noqa: E402

_PERI = [Role.PERIMETER, Role.EXTERNAL_PERIMETER, Role.OVERHANG_PERIMETER]


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def _wall_rows(program):
    m = program.moves
    fw = geometry.flow_widths(m, geometry.filament_diameter(program)[0])
    sel = m["extrude"] & np.isin(m["role"], _PERI) & np.isfinite(fw) & (m["layer"] >= 0)
    rows = np.flatnonzero(sel)
    return m, fw, np.split(rows, np.flatnonzero(np.diff(m["layer"][rows])) + 1)


def _walls_chains(m, fw, groups):
    for r in groups:
        bead_union(m["x0"][r], m["y0"][r], m["x1"][r], m["y1"][r], fw[r] / 2)


def _walls_naive(m, fw, groups):
    for r in groups:
        ends = np.stack([np.c_[m["x0"][r], m["y0"][r]], np.c_[m["x1"][r], m["y1"][r]]], axis=1)
        seg = shapely.linestrings(ends)
        shapely.union_all(shapely.buffer(seg, fw[r] / 2, quad_segs=4))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", help="folder for the sliced files (default: a temporary folder)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="tower only, 3 repeats")
    args, _ = ap.parse_known_args(argv)
    repeats = 3 if args.quick else args.repeats
    tmp = tempfile.TemporaryDirectory() if args.out is None else None
    out = Path(args.out if args.out else tmp.name) / "bench_geometry"
    out.mkdir(parents=True, exist_ok=True)

    cases = [("tower", "prusa", "mixed"), ("tower", "cura", "mixed"), ("tower", "prusa", "solid")]
    if not args.quick:
        cases += [("ohs", "prusa", "mixed"), ("ohs", "cura", "solid")]
    print(f"loadpath layer geometry, median of {repeats} runs, one process")
    print(f"{'file':28s} {'layers':>6s} {'moves':>7s} {'parse s':>8s} {'geometry s':>10s} {'ms/layer':>8s} "
          f"{'geo/parse':>9s} {'walls s':>8s} {'naive s':>8s} {'naive/walls':>11s}")
    for part, slicer, setting in cases:
        stl = out / f"{part}.stl"
        if not stl.exists():
            slicing.write_stl(slicing.PARTS[part](), stl)
        path = out / f"{slicer}-{part}-{setting}.gcode"
        if not path.exists():
            conf = {("prusa", "mixed"): slicing.PRUSA_MIXED, ("prusa", "solid"): slicing.PRUSA_SOLID,
                    ("cura", "mixed"): slicing.CURA_MIXED,
                    ("cura", "solid"): slicing.CURA_SOLID}[slicer, setting]
            (slicing.slice_prusa if slicer == "prusa" else slicing.slice_cura)(stl, path, **conf)
        program = gcode.read(path)
        t_parse = _median_time(lambda: gcode.read(path), repeats)  # noqa: B023
        t_geo = _median_time(lambda: geometry.layer_geometry(program), repeats)  # noqa: B023
        m, fw, groups = _wall_rows(program)
        t_walls = _median_time(lambda: _walls_chains(m, fw, groups), repeats)  # noqa: B023
        t_naive = _median_time(lambda: _walls_naive(m, fw, groups), repeats)  # noqa: B023
        n = len(program.layers)
        print(f"{path.name:28s} {n:6d} {len(program.moves):7d} {t_parse:8.3f} {t_geo:10.3f} "
              f"{1e3 * t_geo / n:8.2f} {t_geo / t_parse:9.1f} {t_walls:8.3f} {t_naive:8.3f} "
              f"{t_naive / t_walls:11.1f}")
    if tmp is not None:
        tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
