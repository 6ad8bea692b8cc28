"""Lean output (issue 17): file size, vertices and beads of the splice for bead-run settings.

Usage::

    python benchmarks/bench_lean.py WORK [--parts bar,beam,...] [--slicers prusa,cura]
                                         [--engine swarm,streamlines] [--example]
                                         [--variant NAME=key:value,key:value ...] [--compare]

The solid (100 %) slices of ``bench_printability.py``'s parts (made in ``WORK`` when missing) and,
with ``--example``, the shipped example are run through the pipeline once per engine with a result
cache in ``WORK/cache``: every variant of :class:`loadpath.splice.RunOptions` splices the same
paths.  Per file and variant: the output's bytes against the input's, the ``G1`` lines and
``;WIDTH:`` markers in the replaced blocks, and the splice check's problems.  With ``--compare``
``loadpath compare`` then predicts, per file, the stiffness, failure load and coverage of every
variant's output against the slicer's file.  Rows go to ``WORK/bench_lean.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "benchmarks"))
sys.path.insert(0, str(REPO / "tests"))


def _cases(work: Path, parts: list[str], slicers: list[str], example: bool) -> list[tuple[str, Path, Path]]:
    """(tag, G-code, load case) of every solid slice asked for."""
    import bench_printability as bp
    import slicing

    out = []
    if example:
        out.append(("example", REPO / "examples" / "ohs.gcode", REPO / "examples" / "ohs.toml"))
    table = bp._parts()
    for name in parts:
        mesh, case_text = table[name]
        stl = slicing.write_stl(mesh, work / f"{name}.stl")
        case = work / f"{name}.toml"
        case.write_text(case_text, encoding="utf-8")
        for slicer, label, sets, kind in bp._slices(name):
            if slicer not in slicers or kind != "solid":
                continue
            g = work / f"{name}-{slicer}-{label.replace('%', '')}.gcode"
            if not g.exists():
                (slicing.slice_prusa if slicer == "prusa" else slicing.slice_cura)(stl, g, **sets)
            out.append((g.stem, g, case))
    return out


def _variant(text: str) -> tuple[str, dict]:
    name, _, body = text.partition("=")
    kw = {}
    for item in filter(None, body.split(",")):
        k, _, v = item.partition(":")
        kw[k] = float(v)
    return name, kw


def _run(
    gcode_path: Path, case_path: Path, engine: str, variants: dict[str, dict], work: Path, cache
) -> list[dict]:
    from loadpath import gcode, loadcase, pipeline
    from loadpath.plugin import settings as settings_mod
    from loadpath.pipeline.paths import default_workers

    program = gcode.read(gcode_path)
    lc = loadcase.read(case_path)
    s = settings_mod.resolve(program, toolpath=lc.toolpath, cli={"engine": engine, "replace": ("solid",)})
    opts = pipeline.PipelineOptions(
        engine=s.engine, pitch=s.pitch, principal=s.principal, replace=tuple(s.replace), stagger=s.stagger,
        link=s.link, workers=min(s.jobs or default_workers(), 2), check=s.check,
    )
    base = settings_mod.splice_options(s)
    size_in = gcode_path.stat().st_size
    rows = []
    for name, kw in variants.items():
        sp = dataclasses.replace(base, runs=dataclasses.replace(base.runs, **kw))
        r = pipeline.run(program, lc, opts, sp, cache=cache)
        out = work / f"{gcode_path.stem}.{engine}.{name}.gcode"
        out.write_bytes(r.data)
        lines = r.data.split(b"\n")
        g1 = widths = 0
        for br in r.splice.blocks:
            for a, z in r.splice.output_ranges(program, br.block):
                for ln in lines[a:z]:
                    g1 += ln.startswith(b"G1 ") and b" E" in ln
                    widths += ln.startswith(b";WIDTH:")
        rows.append(
            dict(
                file=gcode_path.stem, engine=engine, variant=name, out=str(out), slicer=str(gcode_path),
                case=str(case_path), ratio=len(r.data) / size_in, g1=g1, widths=widths,
                blocks=len(r.splice.blocks), check=len(r.check.problems) if r.check else -1,
            )
        )
        print(json.dumps(rows[-1]), flush=True)
    return rows


def _compare(rows: list[dict], work: Path) -> None:
    by = {}
    for r in rows:
        by.setdefault((r["slicer"], r["case"]), []).append(r)
    for (slicer, case), rs in by.items():
        js = work / f"compare.{Path(slicer).stem}.json"
        outs = [r["out"] for r in rs]
        exe = str(REPO / ".venv/bin/loadpath")
        cmd = [exe, "compare", slicer, *outs, "--loadcase", case, "--json", str(js)]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        got = json.loads(js.read_text())
        ref = got[0]
        for r, c in zip(rs, got[1:], strict=True):
            r["compare"] = c
            r["compare_ref"] = ref
            shown = {k: c.get(k) for k in c if "relative" in k or "coverage" in k}
            print(r["file"], r["engine"], r["variant"], shown, flush=True)


def main(argv: list[str] | None = None) -> int:
    from loadpath.cache import Cache

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("work")
    ap.add_argument("--parts", default="bar,beam,bracket,islands")
    ap.add_argument("--slicers", default="prusa,cura")
    ap.add_argument("--engine", default="swarm,streamlines")
    ap.add_argument("--example", action="store_true")
    ap.add_argument("--variant", action="append", default=[])
    ap.add_argument("--compare", action="store_true")
    args = ap.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    variants = dict(_variant(v) for v in args.variant) or {"default": {}}
    cache = Cache(work / "cache")
    rows = []
    parts = [p for p in args.parts.split(",") if p]
    for tag, g, case in _cases(work, parts, args.slicers.split(","), args.example):
        for engine in args.engine.split(","):
            rows += _run(g, case, engine, variants, work, cache)
    if args.compare:
        _compare(rows, work)
    old = work / "bench_lean.json"
    prev = json.loads(old.read_text()) if old.exists() else []
    old.write_text(json.dumps(prev + rows, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
