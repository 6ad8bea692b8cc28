#!/usr/bin/env python3
"""Regenerate the shipped example ``examples/ohs.gcode`` with the real PrusaSlicer 2.5.

The open-hole tensile specimen (ASTM D5766: 150 x 36 x 2 mm, 6 mm hole) is built with trimesh +
manifold3d and sliced with the flattened PrusaSlicer MK3S presets (``tests/slicing.py``) at 100 %
rectilinear infill with 3 top and 3 bottom solid layers, so the file has exposed skins (layer 1,
layer 10), internal ``Solid infill`` layers (2-3, 8-9) and 100 % ``Internal infill`` layers (4-7):
internal solid infill for loadpath's default ``replace = ["solid"]``.

Usage (from the repository root)::

    .venv/bin/python scripts/make_example.py [--out examples]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

import slicing  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=REPO / "examples", help="output folder")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        stl = slicing.write_stl(slicing.ohs_mesh(), Path(tmp) / "ohs.stl")
        gcode = slicing.slice_prusa(stl, Path(tmp) / "ohs.gcode", **slicing.PRUSA_EXAMPLE)
        args.out.mkdir(parents=True, exist_ok=True)
        target = args.out / "ohs.gcode"
        tmp_target = target.with_suffix(".gcode.tmp")
        tmp_target.write_bytes(gcode.read_bytes())
        tmp_target.replace(target)
    print(f"wrote {target} ({slicing.prusa_version()}, overrides {slicing.PRUSA_EXAMPLE})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
