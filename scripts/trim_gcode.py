#!/usr/bin/env python3
"""Trim a real slicer G-code file for the test data: keep its header, its first N layers and its
trailer (end G-code, statistics, config block), drop the layers after the N-th.

Every kept line is the original line, byte for byte; only whole layers at the top are removed, so
the result is what the slicer writes for the part cut at that height (the feature and width markers
stay valid: slicers write ``;TYPE:`` only when it changes, also across layers, so removing layers in
the middle would relabel the next kept layer's first moves).

Usage::

    .venv/bin/python scripts/trim_gcode.py IN.gcode OUT.gcode [--layers 3]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from loadpath import gcode


def trim(data: bytes, layers: int) -> bytes:
    program = gcode.parse(data)
    if len(program.layers) <= layers:
        return data
    return program.replace_lines([(program.layers[layers].start, program.print_end, b"")])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("src", type=Path)
    ap.add_argument("dst", type=Path)
    ap.add_argument("--layers", type=int, default=3, help="first layers to keep")
    args = ap.parse_args(argv)
    out = trim(args.src.read_bytes(), args.layers)
    args.dst.write_bytes(out)
    print(f"{args.src} -> {args.dst}: {len(out)} bytes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
