#!/usr/bin/env python3
"""Mutation fuzzing of ``loadpath inspect`` and ``loadpath run`` on real slicer files.

Each input is a real G-code file with one to three mutations: byte (flip, insert, delete), line
(delete, duplicate, swap, cut the file there) or number (decimal point moved or dropped, scaled by a
power of ten, negated, made 309+ digits long, sign or letter garbage).  The seeds are the committed
real files (``tests/data/**``, ``examples/ohs.gcode``, any ``--extra`` files) and, with ``--slice``,
small parts sliced here by the real PrusaSlicer 2.5 and CuraEngine 4.13 (``tests/slicing.py``): a
20 x 6 mm specimen, two islands and a small L-bracket, a few layers each, so that one ``run`` takes
about a second and one ``inspect`` a few tens of milliseconds.

A fork server runs the cases: this process imports loadpath and runs every command once on an
unmutated seed (so imports, numba kernels and gmsh are warm), then forks one child per case.  The
child runs the real command line, ``loadpath.plugin.cli.main``, with its stdout and stderr on files,
a CPU-time limit (``RLIMIT_CPU``, ``--hang`` s) and an address-space limit (``--mem`` GiB); the
parent waits for it with a wall-clock limit (``--wall`` s, for a case that blocks) and then kills
its process group, so every case is isolated (nothing a case leaves in memory reaches the next) and
the catch-all behaves as in the real program.  Each case is classified:

- ``ok`` (exit 0) or ``refused`` (exit 1 with exactly one ``loadpath: ...`` line on stderr);
- ``traceback``: an ``internal error`` line (the catch-all caught an unexpected exception), any
  exception escaping ``main``, a ``Traceback`` on stderr or a crash (a signal);
- ``memory``: ``out of memory`` (an unbounded allocation hit the ``--mem`` limit);
- ``hang``: more than ``--hang`` s of CPU time, or ``--wall`` s of wall time;
- ``multi-line``: a refusal of more than one line (or none);
- ``changed``: the input file's bytes differ afterwards;
- ``leftover``: a process of the case's group still alive after it ended.

Usage::

    nice -n 10 python scripts/fuzz.py --slice --n 100000 --run-every 50 --seed 1 --out /tmp/fuzz

prints a progress line every ``--report`` cases, keeps the counts in ``OUT/counts.json`` (rewritten
every ``--report`` cases, so a stopped run still has its figures) and ends with a table; the failing
inputs are kept in ``OUT`` with their messages.  ``--selftest`` checks that the harness itself sees a
traceback, a multi-line refusal, a hang and a changed input.  ``tests/hardening/test_fuzz.py`` runs
the same mutators and harness under hypothesis within a bounded budget in CI.

(Over 400 lines: one tool, its mutators, its fork harness with the harness's self-test and its
driver; the CI test imports the first two from here.)
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import random
import re
import resource
import select
import signal
import sys
import time
import traceback
from typing import NamedTuple
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from cases import GRIP_PULL as CASE  # noqa: E402  clamped at x_min, pulled at x_max: any part takes it

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


RUN_SOURCES = ("ohs.gcode", "prusaslicer-2.9.2-calicat-mini-arcs-m486.gcode")
"""Files ``run`` mutates: their unmutated run ends well within the hang limit on two busy cores (the
plant sign takes about 115 s there: slow, not hung)."""



BAD = ("traceback", "memory", "hang", "multi-line", "changed", "leftover")
KINDS = ("ok", "refused", *BAD)
_ESCAPED = 99
"""Exit status of a child whose command let an exception escape ``main``."""


class Outcome(NamedTuple):
    """What one forked case did: exit status (None: killed by a signal), seconds, output."""

    code: int | None
    signal: int | None
    cpu_s: float
    wall_s: float
    timed_out: bool
    leftover: bool
    stderr: str


def _child(target, argv: list[str], stdout: Path, stderr: Path, cpu_s: float, mem_gib: float) -> None:
    """In the forked child: redirect, limit, run ``target(argv)`` and exit with its status."""
    code = _ESCAPED
    try:
        os.setpgid(0, 0)
        for fd, path in ((1, stdout), (2, stderr)):
            f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            os.dup2(f, fd)
            os.close(f)
        # the streams a caller may have swapped (pytest's capture) are rebound to the files
        sys.stdout = open(1, "w", closefd=False, errors="backslashreplace")  # noqa: SIM115
        sys.stderr = open(2, "w", closefd=False, errors="backslashreplace")  # noqa: SIM115
        lim = max(1, int(math.ceil(cpu_s)))
        resource.setrlimit(resource.RLIMIT_CPU, (lim, lim + 5))
        if mem_gib:
            cap = int(mem_gib * 2**30)
            resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        code = int(target(argv) or 0)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    except BaseException:  # noqa: BLE001 (anything escaping main is a finding: keep its traceback)
        traceback.print_exc()
        code = _ESCAPED
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def fork_case(argv: list[str], folder: Path, *, cpu_s: float = 30.0, wall_s: float = 600.0,
              mem_gib: float = 4.0, target=None) -> Outcome:
    """Run ``target(argv)`` (default: ``loadpath.plugin.cli.main``) in a forked child; its outcome."""
    if target is None:
        from loadpath.plugin.cli import main as target
    out, err = folder / "stdout.txt", folder / "stderr.txt"
    sys.stdout.flush()
    sys.stderr.flush()
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:
        _child(target, argv, out, err, cpu_s, mem_gib)
    try:
        os.setpgid(pid, pid)  # also here: the parent may kill the group before the child set it
    except OSError:
        pass
    fd = os.pidfd_open(pid)
    try:
        timed_out = not select.select([fd], [], [], wall_s)[0]
    finally:
        os.close(fd)
    if timed_out:
        _killpg(pid)
    _, status, usage = os.wait4(pid, 0)
    wall = time.monotonic() - t0
    leftover = _killpg(pid)
    code = os.waitstatus_to_exitcode(status)
    text = err.read_text(errors="replace") if err.exists() else ""
    return Outcome(code if code >= 0 else None, -code if code < 0 else None,
                   usage.ru_utime + usage.ru_stime, wall, timed_out, leftover, text)


def _killpg(pgid: int) -> bool:
    """Kill a process group; True if it still had a process."""
    try:
        os.killpg(pgid, signal.SIGKILL)
        return True
    except (ProcessLookupError, PermissionError):
        return False


def judge(o: Outcome, changed: bool, cpu_s: float) -> tuple[str, str]:
    """The class of one case's outcome and the text to keep."""
    text = o.stderr.strip()
    if changed:
        return "changed", text
    if o.timed_out or o.signal == signal.SIGXCPU or o.cpu_s > cpu_s:
        return "hang", f"{o.cpu_s:.1f} s CPU, {o.wall_s:.1f} s wall; {text[-2000:]}"
    if o.signal is not None:
        return "traceback", f"killed by signal {signal.Signals(o.signal).name}; {text[-2000:]}"
    if o.code == _ESCAPED or "internal error" in text or "Traceback" in text:
        return "traceback", text
    if "out of memory" in text:
        return "memory", text
    if o.leftover:
        return "leftover", text
    if o.code == 0:
        return "ok", text
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if o.code == 1 and len(lines) == 1 and lines[0].startswith("loadpath: "):
        return "refused", text
    return "multi-line", text or f"(no message, exit {o.code})"


def argv_for(command: str, path: Path, out: Path, engine: str = "swarm") -> list[str]:
    """The command line of one case."""
    if command == "inspect":
        return ["inspect", str(path)]
    return ["run", str(path), "--loadcase", str(out / "case.toml"), "-o", str(out / "out.gcode"),
            "--engine", engine, "--set", "jobs=1"]


def classify(path: Path, command: str, out: Path, hang_s: float, *, engine: str = "swarm",
             wall_s: float | None = None, mem_gib: float = 4.0, target=None) -> tuple[str, str]:
    """Run one case in a forked child; (class, stderr)."""
    if not (out / "case.toml").exists():
        (out / "case.toml").write_text(CASE)
    before = hashlib.sha256(path.read_bytes()).digest()
    o = fork_case(argv_for(command, path, out, engine), out, cpu_s=hang_s,
                  wall_s=wall_s or max(20 * hang_s, 600.0), mem_gib=mem_gib, target=target)
    changed = hashlib.sha256(path.read_bytes()).digest() != before
    return judge(o, changed, hang_s)


# --------------------------------------------------------------------------------------------------
# small real slices

def small_slices(folder: Path) -> list[Path]:
    """Slice the small seed parts with the real PrusaSlicer and CuraEngine (a few seconds)."""
    import slicing as sl

    folder.mkdir(parents=True, exist_ok=True)
    parts = {"ohs": sl.ohs_mesh(20.0, 6.0, 0.8, 2.0),
             "islands": sl.two_islands_mesh((10.0, 6.0), 3.0, 0.8),
             "bracket": sl.bracket_mesh((16.0, 12.0), 5.0, 0.8, 2.0)}
    done = []
    for name, mesh in parts.items():
        stl = sl.write_stl(mesh, folder / f"{name}.stl")
        for slicer, settings_ in (("prusa", sl.PRUSA_MIXED), ("cura", sl.CURA_MIXED)):
            f = folder / f"small-{slicer}-{name}.gcode"
            if not f.exists():
                (sl.slice_prusa if slicer == "prusa" else sl.slice_cura)(stl, f, **settings_)
            done.append(f)
    return done


RUN_SMALL = ("ohs", "bracket")
"""Small seeds ``run`` mutates (the two islands are not both held by the side clamp: refused)."""


def _selftest(out: Path) -> list[str]:
    """The harness sees each kind of finding (deliberately broken commands); the problems it missed."""
    import loadpath.gcode as lg
    from loadpath.plugin.cli import main

    seed = REPO / "examples" / "ohs.gcode"
    case = out / "self.gcode"
    problems = []

    def broken_parse(argv):  # a bug deep inside the real command: the catch-all's one line
        lg.parse = lambda *a, **k: 1 / 0
        lg.read = lambda *a, **k: 1 / 0
        return main(argv)

    def two_lines(argv):
        print("loadpath: one", file=sys.stderr)
        print("and another", file=sys.stderr)
        return 1

    def escapes(argv):
        raise KeyError("escaped")

    def spins(argv):
        while True:
            pass

    def writes(argv):
        Path(argv[1]).write_bytes(b"changed")
        return 0

    def leaves(argv):
        if os.fork() == 0:
            time.sleep(60)
            os._exit(0)
        return 0

    for want, target, hang in (("traceback", broken_parse, 30.0), ("multi-line", two_lines, 30.0),
                               ("traceback", escapes, 30.0), ("hang", spins, 1.0),
                               ("changed", writes, 30.0), ("leftover", leaves, 30.0),
                               ("ok", None, 30.0)):
        case.write_bytes(seed.read_bytes())
        got, text = classify(case, "inspect", out, hang, target=target)
        if got != want:
            problems.append(f"{getattr(target, '__name__', 'inspect')}: {got} (want {want}): {text[:300]}")
    return problems


# --------------------------------------------------------------------------------------------------

def _warm(sources: list[tuple[Path, bytes]], out: Path) -> None:
    """Run each command once in this process, so forked children start warm."""
    import contextlib
    import io

    import importlib
    import pkgutil

    import loadpath
    from loadpath.plugin.cli import main

    # every module now, so no child reads a source file (they may change while a long run goes on)
    for mod in pkgutil.walk_packages(loadpath.__path__, "loadpath."):
        with contextlib.suppress(Exception):
            importlib.import_module(mod.name)
    small = [p for p, _ in sources if p.name.startswith("small-prusa-ohs")] or [REPO / "examples" / "ohs.gcode"]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        main(["inspect", str(small[0])])
        for engine in ("swarm", "streamlines"):
            main(argv_for("run", small[0], out, engine))
    (out / "out.gcode").unlink(missing_ok=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000, help="inspect cases")
    ap.add_argument("--run-every", type=int, default=50, help="also run `loadpath run` on every k-th case")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hang", type=float, default=30.0, help="CPU seconds after which a case is a hang")
    ap.add_argument("--wall", type=float, default=600.0, help="wall seconds after which a case is a hang")
    ap.add_argument("--mem", type=float, default=4.0, help="address-space limit of a case [GiB]")
    ap.add_argument("--out", type=Path, default=Path("/tmp/loadpath-fuzz"))
    ap.add_argument("--report", type=int, default=100, help="progress line (and counts.json) every N cases")
    ap.add_argument("--extra", nargs="*", default=[], help="more real G-code files to mutate")
    ap.add_argument("--slice", action="store_true", help="also slice small parts as seeds (real slicers)")
    ap.add_argument("--big", type=float, default=0.1,
                    help="with --slice: share of inspect cases drawn from the committed (bigger) files")
    ap.add_argument("--budget", type=float, default=0.0, help="stop after this many wall seconds (0: none)")
    ap.add_argument("--selftest", action="store_true", help="check the harness and stop")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "case.toml").write_text(CASE)
    os.environ.setdefault("LOADPATH_CACHE_DIR", str(args.out / "cache"))
    os.environ.setdefault("XDG_STATE_HOME", str(args.out / "state"))
    if args.selftest:
        problems = _selftest(args.out)
        print("\n".join(problems) or "harness: every kind of finding seen")
        return 1 if problems else 0
    big = [(p, p.read_bytes()) for p in real_files(args.extra)]
    small = [(p, p.read_bytes()) for p in small_slices(args.out / "seeds")] if args.slice else []
    run_src = [s for s in small if any(k in s[0].name for k in RUN_SMALL)] or \
        [s for s in big if s[0].name in RUN_SOURCES]
    _warm(small or big, args.out)
    rng = random.Random(args.seed)
    counts = {c: dict.fromkeys(KINDS, 0) for c in ("inspect", "run")}
    worst = {c: {"cpu_s": 0.0, "wall_s": 0.0} for c in counts}
    per_source: dict[str, int] = {}
    t0 = time.monotonic()
    findings = args.out / "findings.jsonl"

    def checkpoint(i: int, final: bool = False) -> None:
        state = {"cases": i, "wall_s": round(time.monotonic() - t0, 1), "final": final, "counts": counts,
                 "worst": worst, "per_source": per_source, "seed": args.seed, "hang_cpu_s": args.hang,
                 "wall_limit_s": args.wall, "mem_gib": args.mem}
        tmp = args.out / "counts.json.tmp"
        tmp.write_text(json.dumps(state, indent=1))
        os.replace(tmp, args.out / "counts.json")

    i = 0
    for i in range(args.n):
        if args.budget and time.monotonic() - t0 > args.budget:
            break
        pool = big if not small or rng.random() < args.big else small
        src, data = rng.choice(pool)
        runs = args.run_every and i % args.run_every == 0
        if runs and src not in [r for r, _ in run_src]:
            src, data = rng.choice(run_src)
        case = args.out / ("case" + src.suffix)
        mutated = mutate(data, rng)
        per_source[src.name] = per_source.get(src.name, 0) + 1
        engine = rng.choice(("swarm", "streamlines"))
        for command in ("inspect", "run") if runs else ("inspect",):
            case.write_bytes(mutated)
            before = hashlib.sha256(mutated).digest()
            o = fork_case(argv_for(command, case, args.out, engine), args.out, cpu_s=args.hang,
                          wall_s=args.wall, mem_gib=args.mem)
            kind, text = judge(o, hashlib.sha256(case.read_bytes()).digest() != before, args.hang)
            counts[command][kind] += 1
            w = worst[command]
            w["cpu_s"], w["wall_s"] = max(w["cpu_s"], round(o.cpu_s, 2)), max(w["wall_s"], round(o.wall_s, 2))
            if kind in BAD:
                keep = args.out / f"{kind}-{command}-{i}{src.suffix}"
                keep.write_bytes(mutated)
                with findings.open("a") as fh:
                    fh.write(json.dumps({"i": i, "command": command, "kind": kind, "source": src.name,
                                         "engine": engine, "file": str(keep), "message": text[:2000]}) + "\n")
            (args.out / "out.gcode").unlink(missing_ok=True)
        if (i + 1) % args.report == 0:
            checkpoint(i + 1)
            print(f"{i + 1} cases, {time.monotonic() - t0:.0f} s: " + json.dumps(counts), flush=True)
    else:
        i = args.n
    checkpoint(i, final=True)
    print("command  " + "  ".join(f"{k:>10}" for k in KINDS))
    for command, c in counts.items():
        print(f"{command:<8} " + "  ".join(f"{c[k]:>10}" for k in KINDS))
    print(f"{time.monotonic() - t0:.0f} s; worst case {json.dumps(worst)}; findings in {findings}")
    return 1 if any(c[k] for c in counts.values() for k in BAD) else 0


if __name__ == "__main__":
    sys.exit(main())
