#!/usr/bin/env python3
"""Mutation fuzzing of ``loadpath inspect`` and ``loadpath run`` on real slicer files.

Each input is a real G-code file (``tests/data/**``, ``examples/ohs.gcode`` and any ``--extra``
files) with one to three mutations: byte (flip, insert, delete), line (delete, duplicate, swap, cut
the file there) or number (decimal point moved or dropped, scaled by a power of ten, negated, made
309+ digits long, sign or letter garbage).  Every case runs the command in this process through
``loadpath.plugin.cli.main`` with a 30 s CPU-time alarm (and a 600 s wall-clock one for a case
that blocks) and is classified:

- ``ok`` (exit 0) or ``refused`` (exit 1 with exactly one ``loadpath: ...`` line on stderr);
- ``traceback``: an ``internal error`` line (the catch-all caught an unexpected exception) or any
  exception escaping ``main``;
- ``hang``: more than ``--hang`` s of CPU time in this process, or 20x that of wall time;
- ``multi-line``: a refusal of more than one line;
- ``changed``: the input file's bytes differ afterwards.

Usage::

    python scripts/fuzz.py --n 100000 --run-every 50 --seed 1 --out /tmp/fuzz   # nice -n 19 ...

prints a progress line every ``--report`` cases and a final table; the failing inputs are kept in
``--out`` with their messages.  ``tests/hardening/test_fuzz.py`` runs the same mutators under
hypothesis within a bounded budget in CI.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import random
import re
import signal
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CASE = """version = 1
[[supports]]
name = "clamp"
where = { side = "x_min", within = 10.0 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { side = "x_max", within = 10.0 }
force = [1000.0, 0.0, 0.0]
"""

_NUM = re.compile(rb"(?<=[XYZEFIJR])-?\d*\.?\d+")


def real_files(extra: list[str] = ()) -> list[Path]:
    """The real slicer files the mutations start from."""
    files = sorted((REPO / "tests" / "data").rglob("*.gcode")) + [REPO / "examples" / "ohs.gcode"]
    return [*files, *map(Path, extra)]


def _mutate_number(data: bytes, rng: random.Random) -> bytes:
    nums = list(_NUM.finditer(data, rng.randrange(max(1, len(data) // 4)), len(data)))[:400]
    if not nums:
        return data
    m = rng.choice(nums)
    s = m.group()
    neg = s.startswith(b"-")
    digits = s.lstrip(b"-").replace(b".", b"")
    op = rng.randrange(8)
    if op == 0 and b"." in s:  # decimal point moved right by one
        i = s.index(b".")
        t = s[:i] + s[i + 1 : i + 2] + b"." + s[i + 2 :] if i + 2 <= len(s) else s.replace(b".", b"")
    elif op == 1:  # point dropped
        t = s.replace(b".", b"")
    elif op == 2:
        t = (b"-" if neg else b"") + digits + b"0" * rng.randrange(1, 6)
    elif op == 3:
        t = s[1:] if neg else b"-" + s
    elif op == 4:
        t = b"1" + b"9" * rng.randrange(300, 340)
    elif op == 5:
        t = rng.choice([b"nan", b"inf", b"1e5", b"--1", b"1.2.3", b".", b"-", b"+5", b"0x10"])
    elif op == 6:
        t = b"0"
    else:
        t = s[: max(1, len(s) // 2)]
    return data[: m.start()] + t + data[m.end() :]


def _mutate_bytes(data: bytes, rng: random.Random) -> bytes:
    i = rng.randrange(len(data))
    op = rng.randrange(3)
    if op == 0:
        return data[:i] + bytes([data[i] ^ (1 << rng.randrange(8))]) + data[i + 1 :]
    if op == 1:
        return data[:i] + bytes([rng.randrange(256)]) + data[i:]
    return data[:i] + data[i + 1 :]


def _mutate_lines(data: bytes, rng: random.Random) -> bytes:
    lines = data.split(b"\n")
    i = rng.randrange(len(lines))
    op = rng.randrange(5)
    if op == 0:
        del lines[i]
    elif op == 1:
        lines.insert(i, lines[i])
    elif op == 2:
        j = rng.randrange(len(lines))
        lines[i], lines[j] = lines[j], lines[i]
    elif op == 3:  # cut the file there (an interrupted upload), maybe inside the line
        lines = lines[:i] + [lines[i][: rng.randrange(len(lines[i]) + 1)]]
    else:
        lines[i] = rng.choice([b"G91", b"M82", b"M83", b"G20", b";TYPE:Internal infill", b";HEIGHT:0",
                               b";WIDTH:0", b"G92 E0", b";LAYER_CHANGE", b"; printing object x", b";MESH:",
                               b"G1 X", b"G2 X10 Y10 I0 J0 E1", b"T7", b"M486 S3"])
    return b"\n".join(lines)


MUTATORS = (_mutate_number, _mutate_bytes, _mutate_lines)


def mutate(data: bytes, rng: random.Random, k: int | None = None) -> bytes:
    """One to three random mutations of ``data``."""
    for _ in range(k or rng.randint(1, 3)):
        if not data:
            break
        data = rng.choice(MUTATORS)(data, rng)
    return data


class Hang(BaseException):
    """Raised by the alarm: the case ran past the hang limit."""


def _alarm(signum, frame):
    raise Hang


def classify(path: Path, command: str, out: Path, hang_s: float) -> tuple[str, str]:
    """Run one case in this process; (class, stderr)."""
    from loadpath.plugin.cli import main

    before = hashlib.sha256(path.read_bytes()).hexdigest()
    argv = ["inspect", str(path)] if command == "inspect" else \
        ["run", str(path), "--loadcase", str(out / "case.toml"), "-o", str(out / "out.gcode")]
    err, sink = io.StringIO(), io.StringIO()
    # a hang is hang_s of CPU time (ITIMER_PROF): on a machine shared by many jobs under nice 19 a
    # 3 s case can take minutes of wall time; a blocked case (no CPU) is caught by a wall-clock limit
    old = {s: signal.signal(s, _alarm) for s in (signal.SIGALRM, signal.SIGPROF)}
    signal.setitimer(signal.ITIMER_PROF, hang_s)
    signal.setitimer(signal.ITIMER_REAL, max(20 * hang_s, 600.0))
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(sink):
            code = main(argv)
    except Hang:
        return "hang", err.getvalue()
    except BaseException as exc:  # noqa: BLE001 (anything escaping main is a finding)
        return "traceback", f"{type(exc).__name__}: {exc}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.setitimer(signal.ITIMER_PROF, 0)
        for s, h in old.items():
            signal.signal(s, h)
    text = err.getvalue().strip()
    if hashlib.sha256(path.read_bytes()).hexdigest() != before:
        return "changed", text
    if "internal error" in text or "Traceback" in text:
        return "traceback", text
    if code == 0:
        return "ok", text
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if code == 1 and len(lines) == 1 and lines[0].startswith("loadpath: "):
        return "refused", text
    if code == 1 and not lines:
        return "multi-line", "(no message)"
    return "multi-line", text


BAD = ("traceback", "hang", "multi-line", "changed")
RUN_SOURCES = ("ohs.gcode", "prusaslicer-2.9.2-calicat-mini-arcs-m486.gcode")
"""Files ``run`` mutates: their unmutated run ends well within the hang limit on two busy cores (the
plant sign takes about 115 s there: slow, not hung)."""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000, help="inspect cases")
    ap.add_argument("--run-every", type=int, default=50, help="also run `loadpath run` on every k-th case")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hang", type=float, default=30.0, help="CPU seconds after which a case is a hang")
    ap.add_argument("--out", type=Path, default=Path("/tmp/loadpath-fuzz"))
    ap.add_argument("--report", type=int, default=100, help="progress line every N cases")
    ap.add_argument("--extra", nargs="*", default=[], help="more real G-code files to mutate")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "case.toml").write_text(CASE)
    sources = [(p, p.read_bytes()) for p in real_files(args.extra)]
    rng = random.Random(args.seed)
    counts = {c: {k: 0 for k in ("ok", "refused", *BAD)} for c in ("inspect", "run")}
    t0 = time.monotonic()
    findings = args.out / "findings.jsonl"
    for i in range(args.n):
        src, data = rng.choice(sources)
        case = args.out / ("case" + src.suffix)
        case.write_bytes(mutate(data, rng))
        runs = args.run_every and i % args.run_every == 0
        if runs and src.name not in RUN_SOURCES:
            src, data = next((p, d) for p, d in sources if p.name == "ohs.gcode")
            case = args.out / ("case" + src.suffix)
            case.write_bytes(mutate(data, rng))
        for command in ("inspect", "run") if runs else ("inspect",):
            kind, text = classify(case, command, args.out, args.hang)
            counts[command][kind] += 1
            if kind in BAD:
                keep = args.out / f"{kind}-{command}-{i}{src.suffix}"
                keep.write_bytes(case.read_bytes())
                with findings.open("a") as fh:
                    fh.write(json.dumps({"i": i, "command": command, "kind": kind, "source": src.name,
                                         "file": str(keep), "message": text[:2000]}) + "\n")
            (args.out / "out.gcode").unlink(missing_ok=True)
        if (i + 1) % args.report == 0:
            print(f"{i + 1} cases, {time.monotonic() - t0:.0f} s: " + json.dumps(counts), flush=True)
    print("command  " + "  ".join(f"{k:>10}" for k in ("ok", "refused", *BAD)))
    for command, c in counts.items():
        print(f"{command:<8} " + "  ".join(f"{c[k]:>10}" for k in ("ok", "refused", *BAD)))
    print(f"{time.monotonic() - t0:.0f} s; findings in {findings}")
    return 1 if any(c[k] for c in counts.values() for k in BAD) else 0


if __name__ == "__main__":
    sys.exit(main())
