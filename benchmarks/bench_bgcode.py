"""Binary G-code benchmark: decode and encode throughput, beside libbgcode (C++) in the same run.

Usage::

    python benchmarks/bench_bgcode.py [OUT_DIR] [--part tower] [--repeats 7] [--quick]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

The input is real: PrusaSlicer 2.5 slices a test part (``tests/slicing.py``; default the 24 mm
twisted tower, 120 layers, MK3S presets), libbgcode's converter (``pybgcode``, the ``test`` extra)
turns the ASCII file into binary G-code with PrusaSlicer's parameters (Heatshrink 12/4 + MeatPack
with comments, Deflate metadata, CRC32). Then, median of the repeats, one core:

- loadpath ``decode`` (bytes -> text + metadata; CRC32 checked) and ``encode`` (text -> bytes), in MB/s
  of G-code text;
- the stages of ``decode``/``encode`` (Heatshrink, MeatPack), to show where the time goes;
- libbgcode's binary -> ASCII and ASCII -> binary converters on the same file (file to file, so they
  also parse and render the ASCII header: an upper bound on its decode/encode cost), as a reference.

The printed ratio is loadpath time / libbgcode time.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from loadpath.gcode import bgcode
from loadpath.gcode.bgcode import heatshrink, meatpack
from loadpath.gcode.bgcode.blocks import BlockType, ChecksumType, decompress, iter_blocks

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
import slicing  # noqa: E402


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def _reference(pybgcode, src: Path, dst: Path, to_binary: bool) -> None:
    fin = pybgcode.open(str(src), "r" if to_binary else "rb")
    fout = pybgcode.open(str(dst), "wb" if to_binary else "w")
    try:
        if to_binary:
            cfg = pybgcode.get_config()
            cfg.compression.print_metadata = pybgcode.CompressionType.Deflate  # as PrusaSlicer
            res = pybgcode.from_ascii_to_binary(fin, fout, cfg)
        else:
            res = pybgcode.from_binary_to_ascii(fin, fout, True)
    finally:
        pybgcode.close(fout)
        pybgcode.close(fin)
    if res != pybgcode.EResult.Success:
        raise RuntimeError(f"libbgcode failed: {res}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out_dir", type=Path, nargs="?", default=None,
                    help="folder for the sliced files (default: temporary)")
    ap.add_argument("--part", default="tower", choices=sorted(slicing.PARTS))
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="3 repeats")
    args, _ = ap.parse_known_args(argv)
    if args.quick:
        args.repeats = 3
    try:
        import pybgcode
    except ImportError:
        print("pybgcode is not installed: pip install -e .[test]")
        return 1

    work = (args.out_dir / "bgcode") if args.out_dir else Path(tempfile.mkdtemp(prefix="bench_bgcode_"))
    work.mkdir(parents=True, exist_ok=True)
    stl = slicing.write_stl(slicing.PARTS[args.part](), work / f"{args.part}.stl")
    ascii_path = slicing.slice_prusa(stl, work / f"{args.part}.gcode", **slicing.PRUSA_MIXED)
    bin_path = work / f"{args.part}.bgcode"
    _reference(pybgcode, ascii_path, bin_path, to_binary=True)
    data = bin_path.read_bytes()
    bg = bgcode.decode(data)
    text = bg.gcode.encode("utf-8", "surrogateescape")
    mb = len(text) / 1e6

    blocks = [b for b in iter_blocks(data, ChecksumType.CRC32) if b.type == BlockType.GCODE]
    payloads = [decompress(b) for b in blocks]
    chunks = [meatpack.unpack(p) for p in payloads]
    rows = [
        ("loadpath decode (whole file)", _median_time(lambda: bgcode.decode(data), args.repeats)),
        ("loadpath encode (whole file)", _median_time(lambda: bgcode.encode(bg), args.repeats)),
        ("  Heatshrink 12/4 decompress (heatshrink2, C)",
         _median_time(lambda: [decompress(b) for b in blocks], args.repeats)),
        ("  MeatPack unpack (numpy)",
         _median_time(lambda: [meatpack.unpack(p) for p in payloads], args.repeats)),
        ("  MeatPack pack (numpy)", _median_time(lambda: [meatpack.pack(c) for c in chunks], args.repeats)),
        ("  Heatshrink 12/4 compress (heatshrink2, C)",
         _median_time(lambda: [heatshrink.compress(p, 12, 4) for p in payloads], args.repeats)),
    ]
    ref_dec = _median_time(lambda: _reference(pybgcode, bin_path, work / "ref.gcode", False), args.repeats)
    ref_enc = _median_time(lambda: _reference(pybgcode, ascii_path, work / "ref.bgcode", True), args.repeats)

    print(f"input: {slicing.prusa_version()} '{args.part}' (MK3S, PRUSA_MIXED) -> libbgcode "
          f"{pybgcode.version()}: {len(data) / 1e6:.3f} MB binary, {mb:.3f} MB G-code text, "
          f"{len(blocks)} G-code blocks; median of {args.repeats}")
    print()
    print(f"| {'step':46s} | {'time (ms)':>9s} | {'MB/s of text':>12s} |")
    print(f"|{'-' * 48}|{'-' * 11}|{'-' * 14}|")
    for name, t in rows:
        print(f"| {name:46s} | {t * 1e3:9.1f} | {mb / t:12.1f} |")
    for name, t in (("libbgcode binary -> ASCII (file to file)", ref_dec),
                    ("libbgcode ASCII -> binary (file to file)", ref_enc)):
        print(f"| {name:46s} | {t * 1e3:9.1f} | {mb / t:12.1f} |")
    print()
    print(f"decode: loadpath / libbgcode = {rows[0][1] / ref_dec:.1f}x the time; "
          f"encode: {rows[1][1] / ref_enc:.1f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
