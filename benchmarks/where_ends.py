"""Where the retractions of loadpath's infill come from (issue 19): a diagnostic, not a benchmark.

Usage::

    python benchmarks/where_ends.py GCODE CASE.toml [--engine default] [--replace solid]

Runs loadpath on the file (as ``loadpath run`` does) and, in the replaced blocks of the output,
sorts every travel between two of the new paths by what its two ends lie next to: ``edge`` (within
1.5 pitches of the fill region's outer boundary), ``hole`` (of an inner ring), ``inner`` (neither:
a path ending inside the region, where the field ends it -- a neutral axis, a swarm path squeezed
out between two others); with its length, whether it retracted, and whether the two ends belong to
the same island (``<limit``: the end-to-start gap is shorter than ``retract_before_travel``).
Also, per block, the runs' lengths (how many are fragments shorter than 3 pitches).
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
from pathlib import Path

import numpy as np
import shapely


def _where(region, pts: np.ndarray, pitch: float) -> list[str]:
    polys = list(getattr(region, "geoms", [region]))
    ext = shapely.union_all([shapely.LinearRing(p.exterior.coords) for p in polys])
    holes = [shapely.LinearRing(r.coords) for p in polys for r in p.interiors]
    hole = shapely.union_all(holes) if holes else None
    out = []
    for p in shapely.points(pts):
        if hole is not None and hole.distance(p) <= 1.5 * pitch:
            out.append("hole")
        elif ext.distance(p) <= 1.5 * pitch:
            out.append("edge")
        else:
            out.append("inner")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("gcode")
    ap.add_argument("case")
    ap.add_argument("--engine", default="default", help="an engine, or 'default': the product's own choice")
    ap.add_argument("--replace", default="solid")
    ap.add_argument("--principal", default="max_abs")
    args = ap.parse_args(argv)
    from loadpath.gcode import read
    from loadpath.plugin.job import JobRequest, run_job

    out = Path(tempfile.mkdtemp(prefix="where_ends_")) / "out.gcode"
    res = run_job(
        JobRequest(
            Path(args.gcode),
            Path(args.case),
            output=out,
            cli={
                **({} if args.engine == "default" else {"engine": args.engine}),
                "replace": tuple(args.replace.split(",")),
                "principal": args.principal,
            },
        )
    )
    pr = res.pipeline
    program, new = pr.program, read(out)
    rd = program.config.get("retract_before_travel", "1")
    limit = float(str(rd).split(",")[0])
    pitch = float(np.median([j.job.unit.pitch for j in pr.jobs]))
    units = {}
    for j in pr.jobs:
        for u in j.units:
            for b in u.blocks:
                units[b.block_index] = (u.fill_region, b.region)
    kinds: collections.Counter = collections.Counter()
    retracted: collections.Counter = collections.Counter()
    lengths: dict = collections.defaultdict(list)
    run_len: list[float] = []
    n_runs = 0
    for rep in pr.splice.blocks:
        fill, breg = units.get(rep.block, (None, None))
        region = breg if breg is not None else fill
        for a, z in pr.splice.output_ranges(program, rep.block):
            mv = new.moves[new.move_rows(a, z)]
            ext = mv["extrude"]
            # runs of extrusion and the gaps between them
            idx = np.flatnonzero(ext)
            if not len(idx):
                continue
            brk = np.flatnonzero(np.diff(idx) > 1)
            starts = np.r_[idx[0], idx[brk + 1]]
            stops = np.r_[idx[brk], idx[-1]]
            n_runs += len(starts)
            for s, t in zip(starts, stops, strict=True):
                seg = mv[s : t + 1]
                run_len.append(float(np.sum(np.hypot(seg["x1"] - seg["x0"], seg["y1"] - seg["y0"]))))
            for k in range(len(starts) - 1):
                g = mv[stops[k] + 1 : starts[k + 1]]
                p0 = np.array([mv["x1"][stops[k]], mv["y1"][stops[k]]])
                p1 = np.array([mv["x0"][starts[k + 1]], mv["y0"][starts[k + 1]]])
                d = float(np.hypot(*(p1 - p0)))  # end to start (a wipe moves the nozzle back first)
                r = bool(np.any(g["retract"] | g["wipe"]))
                w = _where(region, np.array([p0, p1]), pitch)
                same = True
                if hasattr(region, "geoms"):
                    parts = list(region.geoms)
                    i0 = int(np.argmin([q.distance(shapely.Point(p0)) for q in parts]))
                    i1 = int(np.argmin([q.distance(shapely.Point(p1)) for q in parts]))
                    same = i0 == i1
                key = "-".join(sorted(w)) + ("" if same else " (other island)")
                kinds[key] += 1
                retracted[key] += int(r)
                lengths[key].append(d)
    print(f"pitch {pitch:.3f} mm, retract_before_travel {limit} mm, runs {n_runs}")
    rl = np.array(run_len)
    print(
        f"runs: median {np.median(rl):.1f} mm; shorter than 3 pitches {int(np.sum(rl < 3 * pitch))}, "
        f"than 10 pitches {int(np.sum(rl < 10 * pitch))}"
    )
    print(f"{'travel between':28} {'count':>6} {'retracted':>9} {'<limit':>7} {'median gap mm':>13}")
    for k, c in kinds.most_common():
        ln = np.array(lengths[k])
        print(f"{k:28} {c:6d} {retracted[k]:9d} {int(np.sum(ln < limit)):7d} {np.median(ln):13.2f}")
    print(f"{'total':28} {sum(kinds.values()):6d} {sum(retracted.values()):9d}")
    m = pr.check.problems if pr.check else []
    print("check problems:", len(m))
    return 0


if __name__ == "__main__":
    sys.exit(main())
