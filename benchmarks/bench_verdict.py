"""The verdict against ``loadpath compare`` on the same two files: one model, the same figures.

Usage::

    python benchmarks/bench_verdict.py [OUT_DIR] [--quick]

Real slices (PrusaSlicer 2.5 and CuraEngine 4.13, ``tests/slicing.py``): the L-bracket, the 3-point
beam and the open-hole specimen of ``bench_sparse.py`` (PrusaSlicer gyroid 20 %, ``replace =
sparse``, ``density = "auto"``), the beam, bracket and bar of ``bench_printability.py`` at 100 %
(``replace = solid``, both slicers) and the shipped example.  Each file goes through ``loadpath
run`` (swarm, no result cache), then ``compare_files([slicer's, output])``; the table gives the
verdict's stiffness and failure-load change beside compare's ``relative_stiffness - 1`` and
``relative_failure_load - 1`` (per cent) and the seconds of the verdict and of compare.
``--quick``: the bracket and the example.

Measured 2026-12-04 (load 2-4 on 2 cores), before the verdict shared compare's model (the engine's
paths as beads, sampled every 0.5 mm, on the run's FEA mesh) and after (``stiffness.model``):

====================  ================  ================  ===============
file                  verdict before    compare           verdict after
====================  ================  ================  ===============
bracket sparse 20     +6.1 / -13.6      +19.7 / +8.3      +19.7 / +8.3
beam sparse 20        +5.4 / +156.2     +26.3 / +66.0     +26.3 / +66.0
ohs sparse 20         +22.0 / +35.6     +22.6 / +29.3     +22.6 / +29.3
example (solid)       +0.1 / +12.3      +1.2 / +5.0       +1.2 / +5.0
bar Prusa 100         +1.7 / -28.4      +1.1 / +5.4       +1.1 / +5.4
bar Cura 100          +0.1 / -10.3      -0.8 / +1.4       -0.8 / +1.4
beam Prusa 100        +0.3 / +0.8       +3.1 / -7.4       +3.1 / -7.4
beam Cura 100         +0.3 / +8.2       -0.2 / -4.8       -0.2 / -4.8
bracket Prusa 100     +1.6 / +4.5       +0.8 / -4.6       +0.8 / -4.6
bracket Cura 100      +0.4 / +6.4       -1.6 / -9.8       -1.6 / -9.8
====================  ================  ================  ===============

(stiffness / failure load, per cent over the slicer's file; "after" equals compare to 1e-12.)
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "benchmarks"))
import slicing  # noqa: E402


def files(folder: Path, quick: bool) -> list[tuple[str, Path, Path, str]]:
    """(label, slicer's G-code, load case, replaced kind) of every file measured."""
    import bench_printability as bp
    import bench_sparse as bs

    out = []
    for part in ("bracket",) if quick else ("bracket", "beam", "ohs"):
        g = bs.slice_part(part, "prusa", "gyroid", 20, folder)
        case = folder / f"{part}.toml"
        case.write_text(bs.CASES[part], encoding="utf-8")
        out.append((f"{part} sparse 20", g, case, "sparse"))
    out.append(("example (solid)", REPO / "examples" / "ohs.gcode", REPO / "examples" / "ohs.toml", "solid"))
    if quick:
        return out
    parts = bp._parts()
    for name in ("bar", "beam", "bracket"):
        mesh, text = parts[name]
        stl = slicing.write_stl(mesh, folder / f"p_{name}.stl")
        case = folder / f"p_{name}.toml"
        case.write_text(text, encoding="utf-8")
        g = slicing.slice_prusa(stl, folder / f"p_{name}-prusa100.gcode", **dict(slicing.PRUSA_SOLID))
        out.append((f"{name} Prusa 100", g, case, "solid"))
        g = slicing.slice_cura(stl, folder / f"p_{name}-cura100.gcode", **dict(slicing.CURA_SOLID))
        out.append((f"{name} Cura 100", g, case, "solid"))
    return out


def measure(label: str, src: Path, case: Path, kind: str, folder: Path) -> dict:
    """One file: the run's verdict and compare's row of its output, per cent, and their seconds."""
    from loadpath import loadcase
    from loadpath.plugin.job import JobRequest, run_job
    from loadpath.stiffness import compare_files

    out = folder / (label.replace(" ", "_").replace("(", "").replace(")", "") + ".loadpath.gcode")
    res = run_job(JobRequest(src, case, output=out, cli={"engine": "swarm", "replace": (kind,), "cache": False}))
    if res.error:
        return {"label": label, "error": res.error}
    t0 = time.perf_counter()
    _, r = compare_files([str(src), str(out)], loadcase.read(case))[0]
    v = res.verdict

    def pct(x: float | None) -> float:
        return float("nan") if x is None else 100.0 * x

    return {
        "label": label,
        "verdict": (pct(v.stiffness), pct(v.failure_load)),
        "compare": (pct(r.relative_stiffness - 1.0), pct(r.relative_failure_load - 1.0)),
        "verdict_s": res.times.get("verdict", float("nan")),
        "compare_s": time.perf_counter() - t0,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default=None)
    ap.add_argument("--quick", action="store_true")
    args, _ = ap.parse_known_args(argv)
    folder = Path(args.out or tempfile.mkdtemp(prefix="bench_verdict_"))
    folder.mkdir(parents=True, exist_ok=True)
    print(f"{'file':20s}  {'verdict':>16s}  {'compare':>16s}  {'verdict s':>9s}  {'compare s':>9s}")
    worst = 0.0
    for label, src, case, kind in files(folder, args.quick):
        r = measure(label, src, case, kind, folder)
        if "error" in r:
            print(f"{label:20s}  failed: {r['error']}")
            continue
        (vs, vf), (cs, cf) = r["verdict"], r["compare"]
        worst = max(worst, abs(vs - cs), abs(vf - cf))
        print(f"{label:20s}  {vs:+7.1f} / {vf:+6.1f}  {cs:+7.1f} / {cf:+6.1f}  {r['verdict_s']:9.2f}  {r['compare_s']:9.2f}")
    print(f"largest difference: {worst:.3f} percentage points")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
