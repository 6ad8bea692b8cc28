"""The splice check read piece by piece: the memory of a few hundred thousand lines, not the output's.

:func:`loadpath.splice.verify.check_output` read a whole output into per-line arrays before checking
it: on the 1000-layer specimen (842k lines in, 4.1M out) that read peaked at 1.05 GB above the run's
0.67 GB, the largest part of the run's peak.  :func:`check_pieces` reads the output in pieces of about
``piece_lines`` lines (:func:`loadpath.splice.lineview.read_piece`: each piece starts from the machine
state, feature, width and wipe its previous piece ended in) and checks each piece as it is read;
only per-block extrusions of blocks cut by a piece boundary wait for the next piece.  Its problems,
volume ratios and outside distances are those of :func:`loadpath.splice.verify.check_splice` on the
parsed output, message for message (the first offending line of each check, in the same order).
Measured on that specimen's repeated run (in process, RSS sampled every 10 ms): the check's peak
1715 -> 738 MB, the run's 1715 -> 755 MB (now the verdict line's copy of the output), the check
8.4 -> 4.1 s (less memory to fill; the same load).

With several workers the pieces are read in groups side by side (:func:`loadpath.procs.fork_map`),
each group checked as above.  A group needs the state its first piece starts from, which only the
groups before it know; it starts instead from a guess: the output's layer before the group, read
from the original's state at that layer's marker.  Every state a layer's lines leave behind (X, Y,
Z, F, the retraction, the feature and width markers) is set again within the layer, and absolute E
at a kept marker is the original's when the file passes, so the guess is where the group before
ended; the carries are compared once the groups are back (up to the rounding of summed relative
moves; E only when a later line has absolute E), and a group whose guess was not is read again from
the true state.  The groups' running reductions are then merged in file order, and a block read by
two groups is checked from both groups' extrusions.  The 1000-layer specimen's repeated run, two
workers: the check alone, in process, on the same output (4.1M lines), median of 3: 3.28 -> 1.91 s.

Pieces are cut only at the output's places of the original's layer markers (kept lines), between
its first and its last layer: no config block or thumbnail (the header's and the trailer's
multi-line marker blocks) spans a cut.  The config the machine state needs (volumetric E) is read
from the header and the trailer before the pieces.

(Over 400 lines, :func:`_read` over 100: the seven checks of
:func:`~loadpath.splice.verify.check_splice`, each kept as a running reduction over the pieces; they
share the piece loop and its arrays, so they stay in one function, but for the per-block checks 3
and 7, :func:`_block_checks`, and the merge of the groups' reductions, :func:`_verdict`.)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import shapely
from loadpath._typing import Region
from loadpath.gcode.blocks import EXTRUDE, RETRACT, WIPE
from loadpath.gcode.flavors import detect_slicer
from loadpath.gcode.lines import check_text, index_lines
from loadpath.gcode.markers import Markers, read_markers
from loadpath.gcode.model import Program
from loadpath.gcode.parse import _HEAD, _print_end, _volumetric_area
from loadpath.gcode.state import LineState, Start
from loadpath.gcode.words import G, M, tokenize
from loadpath.splice.lineview import EXTRUSION_DTYPE, FAMILIES, Carry, read_piece
from loadpath.splice.splicer import SpliceResult
from loadpath.splice.verify import (
    SpliceCheck,
    emptied_features,
    features_differ,
    first_difference,
    kept_state,
    parked_lines,
    state_value,
    volume_ratio,
)

__all__ = ["check_pieces", "PIECE_LINES"]

PIECE_LINES = 200_000
"""Lines per piece by default: about 55 MB of reading at its peak (about 270 bytes a line)."""

_BLOCK = 1 << 23  # bytes per block when counting line endings


def _line_offsets(data: bytes, lines: list[int]) -> list[int]:
    r"""Byte offset where each of ``lines`` (sorted, >= 1) starts: just after its previous line's ``\\n``."""
    counts = np.array([data.count(b"\n", a, a + _BLOCK) for a in range(0, len(data), _BLOCK)], dtype=np.int64)
    before = np.concatenate([[0], np.cumsum(counts)])
    out, found = [], {}
    for line in lines:
        k = int(np.searchsorted(before, line, "left")) - 1  # block holding the line-th '\n'
        if k not in found:
            a = k * _BLOCK
            found[k] = np.flatnonzero(np.frombuffer(data, np.uint8, min(_BLOCK, len(data) - a), a) == 10)
        out.append(k * _BLOCK + int(found[k][line - int(before[k]) - 1]) + 1)
    return out


def _cuts(original: Program, lmap: np.ndarray, n_out: int, piece_lines: int) -> list[int]:
    """Output lines where pieces start (0 first): places of the original's layer markers."""
    starts = [int(lmap[ly.start]) for ly in original.layers[1:] if lmap[ly.start] > 0]
    cuts, last = [0], 0
    for j in starts:
        if j - last >= piece_lines and j < n_out:
            cuts.append(j)
            last = j
    return cuts


def _config(data: bytes, head: int, tail: int) -> dict[str, str]:
    """Read the config blocks of ``data[:head]`` and ``data[tail:]`` (the header's and the trailer's)."""
    config: dict[str, str] = {}
    for part in (data[:head], data[tail:]):
        if part:
            idx = index_lines(part)
            config.update(read_markers(part, idx, tokenize(idx)).config)
    return config


def check_pieces(
    original: Program,
    data: bytes,
    result: SpliceResult,
    volume_tol: float = 0.03,
    regions: Mapping[int, Region] | None = None,
    retract_length: float = 0.0,
    piece_lines: int = PIECE_LINES,
    workers: int = 1,
    groups: int | None = None,
):
    """:func:`~loadpath.splice.verify.check_splice` of ``data`` read piece by piece (module docstring).

    Parameters
    ----------
    workers : int
        Processes for the groups of pieces (:func:`loadpath.procs.fork_map`).
    groups : int, optional
        Groups of consecutive pieces read on their own, each from a guessed start (module
        docstring); default: one per worker when they fork and there are pieces enough, else one.

    Returns
    -------
    SpliceCheck or None
        None when the output holds a G2/G3 arc (the caller parses it in full: its moves are arc
        chords) or when the original's first or last layer marker has no place in it (no cut is
        known to be safe: the caller reads it whole).
    """
    from loadpath.procs import fork_map, forks

    check_text(data)
    n = original.n_lines
    lmap = result.line_map(n)
    keep = lmap >= 0
    n_out = data.count(b"\n") + (1 if data and data[-1:] != b"\n" else 0)
    if int(lmap.max(initial=-1)) >= n_out:
        return SpliceCheck([f"the output has {n_out} lines, fewer than the kept lines need"])
    cuts = _cuts(original, lmap, n_out, piece_lines)
    # the header (to the first layer marker) and the trailer (from the last one) hold the config
    marks = [int(lmap[original.layers[k].start]) for k in (0, -1)]
    if not all(0 < j < n_out for j in marks):
        return None
    if groups is None:
        groups = workers if forks(workers, 2) and len(cuts) >= 2 * workers else 1
    spread = _groups(cuts, n_out, groups)
    windows = _windows(original, lmap, cuts, spread)
    wanted = sorted({*cuts[1:], *marks, *(w for w, _ in windows.values())})
    at = dict(zip(wanted, _line_offsets(data, wanted), strict=True))
    offsets = [0, *(at[j] for j in cuts[1:]), len(data)]
    cuts.append(n_out)
    so = original.state
    i_k = np.flatnonzero(keep)
    edits = list(result.edits)
    out_start, shift = {}, 0
    for a, z, k in sorted(edits):
        out_start[(a, z)] = a + shift
        shift += k - (z - a)
    count = {(a, z): k for a, z, k in edits}
    spans: dict[int, list[tuple[int, int]]] = {}
    for rep in result.blocks:
        b = original.block(rep.block)
        ranges = b.spans
        spans[rep.block] = [(out_start[r], out_start[r] + count[r]) for r in ranges]
    scan = _Scan(
        original=original,
        data=data,
        cuts=cuts,
        offsets=offsets,
        groups=spread,
        windows={p: (i, at[w], at[cuts[p]]) for p, (w, i) in windows.items()},
        area=_volumetric_area(_config(data, at[marks[0]], at[marks[1]])),
        i_k=i_k,
        j_k=lmap[i_k],
        spans=spans,
        reps={rep.block: rep for rep in result.blocks},
        regions=regions or {},
        volume_tol=volume_tol,
        motion=np.isin(so.cmd[i_k], (G + 0, G + 1, G + 2, G + 3)),
        moving=np.isin(original.kind_of_line[i_k], (EXTRUDE, WIPE)) | np.isin(so.cmd[i_k], (G + 2, G + 3)),
        parked=parked_lines(original, result)[i_k],
    )
    _SCAN[:] = [scan]
    try:
        tallies = fork_map(_read_group, range(len(spread)), workers)
    finally:
        _SCAN.clear()
    for g in range(1, len(tallies)):  # a group whose guessed start was not where the one before ended
        before = tallies[g - 1]
        if before is None or tallies[g] is None:
            return None
        if not _continues(before, tallies[g], any(t.absolute_e for t in tallies[g:])):
            tallies[g] = _read(scan, *spread[g], before.carry, list(before.names))
    if any(t is None for t in tallies):
        return None
    return _verdict(scan, tallies, result, regions or {}, retract_length, n_out)


_SCAN: list = []
"""The :class:`_Scan` :func:`_read_group` reads (set by :func:`check_pieces`; inherited by a fork)."""


@dataclass(frozen=True)
class _Scan:
    """What every group of pieces reads: the original, the output, where its pieces and blocks are.

    ``offsets`` and ``cuts``: byte offset and output line of every piece, then the output's end;
    ``groups``: ``(first piece, piece past the last)`` of each group; ``windows``: per group but the
    first, keyed by its first piece, ``(original line, first byte, byte past the last)`` of the
    output's layer before the group, which its guessed start is read from; ``i_k``, ``j_k``: the
    kept lines in the original and in the output; ``motion``, ``moving``: per kept line, a move
    (its feedrate is checked) and a kept extrusion, wipe or arc (its ends are); ``spans``: per
    replaced block, the output lines of its new text.
    """

    original: Program
    data: bytes
    cuts: list[int]
    offsets: list[int]
    groups: list[tuple[int, int]]
    windows: dict[int, tuple[int, int, int]]
    area: float | None
    i_k: np.ndarray
    j_k: np.ndarray
    spans: dict[int, list[tuple[int, int]]]
    reps: dict
    regions: Mapping[int, Region]
    volume_tol: float
    motion: np.ndarray
    moving: np.ndarray
    parked: np.ndarray


@dataclass
class _Tally:
    """The seven checks' running reductions over one group of pieces.

    ``start`` and ``carry``: the state the group was read from and ended in, ``names`` the feature
    names the carries' codes index (as the group ended); ``start_names`` those ``start`` indexes.
    ``first_bad``: check 2's first problem per state name; ``pending``: extrusions read of blocks
    the group did not hold whole (per span, in file order); ``pairs``: per layer-marker family,
    ``(layer counted from the group's first marker, feature name)`` -> first output line;
    ``absolute_e``: a line of the group's output, or a kept line of the original, has absolute E;
    ``short``: a piece had fewer lines than its cuts say (the output lacks lines the kept ones need).
    """

    start: Carry
    start_names: list[str]
    carry: Carry
    names: list[str]
    kept_line: str | None = None
    first_bad: dict[str, str] = field(default_factory=dict)
    pending: dict[int, list[list[np.ndarray]]] = field(default_factory=dict)
    volume: dict[int, str] = field(default_factory=dict)
    away: dict[int, str] = field(default_factory=dict)
    ratio: dict[int, float] = field(default_factory=dict)
    outside: dict[int, float] = field(default_factory=dict)
    r_lo: float = np.inf
    r_hi: float = -np.inf
    seen_new: bool = False
    back_line: tuple[int, str] | None = None
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(FAMILIES, 0))
    layer_lines: dict[str, list[np.ndarray]] = field(default_factory=lambda: {f: [] for f in FAMILIES})
    pairs: dict[str, dict[tuple[int, str], int]] = field(default_factory=lambda: {f: {} for f in FAMILIES})
    ends_of_print: dict[str, list[np.ndarray]] = field(
        default_factory=lambda: {"end": [], "custom": [], "time": []}
    )
    last_x: int = -1
    absolute_e: bool = False
    short: bool = False


def _groups(cuts: list[int], n_out: int, k: int) -> list[tuple[int, int]]:
    """``k`` (at most) runs of consecutive pieces of about the same number of lines."""
    bounds = np.array([*cuts, n_out])
    aims = np.searchsorted(bounds, [n_out * i / k for i in range(1, k)])
    edges = sorted({0, *(int(a) for a in aims if 0 < a < len(cuts)), len(cuts)})
    return list(zip(edges[:-1], edges[1:], strict=True))


def _windows(original: Program, lmap: np.ndarray, cuts: list[int], groups) -> dict[int, tuple[int, int]]:
    """Per group but the first, keyed by its first piece: ``(output line, original line)`` of the
    last layer marker before the group (where its guessed start is read from)."""
    out = {}
    starts = [(int(lmap[ly.start]), ly.start) for ly in original.layers if lmap[ly.start] > 0]
    for p, _ in groups[1:]:
        before = [s for s in starts if s[0] < cuts[p]]
        if before:
            out[p] = before[-1]
    return out


def _start_before(so: LineState, i: int) -> Start:
    """The machine state the original's line ``i`` starts from, as a :class:`Start`."""
    if i <= 0:
        return Start()
    k = i - 1
    latch = np.flatnonzero((so.cmd[:i] == M + 83) | (so.cmd[:i] == M + 82))
    return Start(
        x=float(so.x[k]),
        y=float(so.y[k]),
        z=float(so.z[k]),
        e=float(so.e[k]),
        f=float(so.f[k]),
        absolute_xyz=bool(so.absolute_xyz[k]),
        e_latch_relative=bool(so.cmd[latch[-1]] == M + 83) if len(latch) else False,
        fw_retracted=bool(so.fw_retracted[k]),
        retracted=float(so.retracted[k]),
        tool=int(so.tool[k]),
    )


def _read_group(g: int) -> _Tally | None:
    """Group ``g`` of :data:`_SCAN`: the first from the file's start, the others from a guess -- the
    output's layer before the group read from the original's state at its marker."""
    scan = _SCAN[0]
    p0, p1 = scan.groups[g]
    names: list[str] = []
    carry = Carry()
    if g > 0:
        if p0 not in scan.windows:
            return None
        line, a, z = scan.windows[p0]
        guess = Carry(start=_start_before(scan.original.state, line))
        carry = read_piece(scan.data[a:z], guess, names, scan.area).carry
    return _read(scan, p0, p1, carry, names)


def _continues(before: _Tally, after: _Tally, e_matters: bool) -> bool:
    """Whether ``after`` was read from the state ``before`` ended in (up to the rounding of sums of
    relative moves).  E's value counts only when a later line has absolute E: a relative E word
    moves by its own value wherever E stands."""
    a, b = before.carry, after.start
    sa, sb = a.start, b.start

    def close(u: float, v: float) -> bool:
        return (np.isnan(u) and np.isnan(v)) or abs(u - v) <= 1e-9 * (1.0 + abs(u))

    name_a = before.names[a.feature] if a.feature >= 0 else None
    name_b = after.start_names[b.feature] if b.feature >= 0 else None
    return (
        all(close(getattr(sa, k), getattr(sb, k)) for k in ("x", "y", "z", "f", "retracted"))
        and (close(sa.e, sb.e) or not e_matters)
        and (sa.absolute_xyz, sa.e_latch_relative, sa.fw_retracted, sa.tool)
        == (sb.absolute_xyz, sb.e_latch_relative, sb.fw_retracted, sb.tool)
        and name_a == name_b
        and close(a.width, b.width)
        and a.wipe == b.wipe
    )


def _read(scan: _Scan, p0: int, p1: int, carry: Carry, names: list[str]) -> _Tally | None:
    """Read and check the pieces ``[p0, p1)`` from ``carry`` (None: an arc; the caller parses it all).

    (Over 100 lines: the checks of one piece in turn, sharing its arrays.)
    """
    original, so, cuts = scan.original, scan.original.state, scan.cuts
    i_k, j_k, spans = scan.i_k, scan.j_k, scan.spans
    t = _Tally(start=carry, start_names=list(names), carry=carry, names=names)
    first, last = cuts[p0], cuts[p1]
    ends = {blk: max((z for _, z in sp), default=0) for blk, sp in spans.items()}
    heads = {blk: min((a for a, _ in sp), default=0) for blk, sp in spans.items()}
    by_end = sorted((blk for blk in spans if ends[blk] > first or p0 == 0), key=lambda blk: ends[blk])
    pending = {blk: [[] for _ in spans[blk]] for blk in by_end}  # extrusions per span, as read
    for p in range(p0, p1):
        a_line, z_line = cuts[p], cuts[p + 1]
        piece = read_piece(scan.data[scan.offsets[p] : scan.offsets[p + 1]], carry, names, scan.area)
        view, st = piece.view, piece.view.state
        if view.n_lines != z_line - a_line:
            t.short = True
            return t
        if view.arc_lines.any():
            return None
        prev_xy = (carry.start.x, carry.start.y)

        # 1. kept lines byte for byte (the runs of kept lines in this piece)
        lo, hi = np.searchsorted(j_k, [a_line, z_line])
        if t.kept_line is None and hi > lo:
            ii, jj = i_k[lo:hi], j_k[lo:hi] - a_line
            brk = np.flatnonzero((np.diff(ii) != 1) | (np.diff(jj) != 1)) + 1
            for s, e in zip(np.r_[0, brk], np.r_[brk, len(ii)], strict=True):
                i0, i1, j0, j1 = int(ii[s]), int(ii[e - 1]) + 1, int(jj[s]), int(jj[e - 1]) + 1
                if original.lines_bytes(i0, i1) != view.lines_bytes(j0, j1):
                    bad = next(i for i in range(i0, i1) if original.line(i) != view.line(j0 + i - i0))
                    t.kept_line = (
                        f"kept line {bad + 1} changed: {original.line(bad)!r} -> "
                        f"{view.line(j0 + bad - i0)!r}"
                    )
                    break

        # 2. machine state on kept lines
        sel = slice(lo, hi)
        ik, jk = i_k[sel], j_k[sel] - a_line

        def differ(name, a, b, tol=0.0, mask=None, ik=ik):
            if name in t.first_bad:
                return
            k = first_difference(a, b, tol, mask)
            if k is not None:
                t.first_bad[name] = (
                    f"{name} differs after kept line {ik[k] + 1} ({original.line(int(ik[k]))!r}): "
                    f"{state_value(a[k])} in the original, {state_value(b[k])} in the output"
                )

        for name, a, b, tol, mask in kept_state(so, st, ik, jk, scan.motion[sel], scan.parked[sel]):
            differ(name, a, b, tol, mask)
        prev_o = np.maximum(ik - 1, 0)
        pj = np.maximum(j_k[sel] - 1, 0) - a_line  # -1: the previous piece's last line
        for axis, before in (("x", prev_xy[0]), ("y", prev_xy[1])):
            col = getattr(st, axis)
            end = f"{axis.upper()} (end of a kept extrusion)"
            differ(end, getattr(so, axis)[ik], col[jk], 1e-6, scan.moving[sel])
            differ(
                f"{axis.upper()} (start of a kept extrusion)",
                getattr(so, axis)[prev_o],
                np.where(pj >= 0, col[np.maximum(pj, 0)], before),
                1e-6,
                scan.moving[sel],
            )
        t.absolute_e = t.absolute_e or bool((~st.e_relative).any() or (~so.e_relative[ik]).any())

        # 3, 7. each block's extrusions, gathered until its spans are read (a block begun before
        # the group goes back with what the group read of it)
        for blk, parts in pending.items():
            for s, (a, z) in enumerate(spans[blk]):
                if z > a_line and a < z_line:
                    lo_s, hi_s = max(a, a_line) - a_line, min(z, z_line) - a_line
                    parts[s].append(view.extrusions(lo_s, hi_s, prev_xy))
        while by_end and ends[by_end[0]] <= z_line:
            blk = by_end.pop(0)
            got = pending.pop(blk)
            if heads[blk] < first and p0 > 0:
                t.pending[blk] = got
                continue
            mv = [np.concatenate(q) if q else np.zeros(0, EXTRUSION_DTYPE) for q in got]
            _block_checks(
                original, scan.reps[blk], mv, scan.volume_tol, scan.regions.get(blk),
                t.volume, t.away, t.ratio, t.outside,
            )

        # 4. retraction bounds in new lines; 5. absolute E backwards
        new_lines = np.ones(view.n_lines, dtype=bool)
        new_lines[jk] = False
        r_new = st.retracted[new_lines]
        if len(r_new):
            t.seen_new = True
            t.r_lo, t.r_hi = min(t.r_lo, float(r_new.min())), max(t.r_hi, float(r_new.max()))
        if t.back_line is None:
            ab = ~st.e_relative
            back = ab & (st.de < -1e-9) & ~np.isin(view.kind_of_line, (RETRACT, WIPE)) & (st.cmd != G + 92)
            if back.any():
                k = int(np.argmax(back))
                t.back_line = (a_line + k, view.line(k))

        # 6. layers and the features extruded in each, for every family of layer markers (layers
        # counted from the group's first marker: -1 is the layer the group began in)
        ext = np.flatnonzero(st.moved_xy & (st.de > 0))
        if len(ext):
            t.last_x = a_line + int(ext[-1])
        for fam in FAMILIES:
            local = piece.layer_lines[fam]
            layer = t.counts[fam] + np.searchsorted(local, ext, "right") - 1
            key = (layer + 1) * 65536 + view.feature_of_line[ext].astype(np.int64) + 1
            uniq, at = np.unique(key, return_index=True)
            got = t.pairs[fam]
            for u, f in zip(uniq.tolist(), at.tolist(), strict=True):
                feat = u % 65536 - 1
                got.setdefault((u // 65536 - 1, names[feat] if feat >= 0 else ""), a_line + int(ext[f]))
            t.counts[fam] += len(local)
            t.layer_lines[fam].append(local + a_line)
        t.ends_of_print["end"].append(piece.end_lines + a_line)
        t.ends_of_print["custom"].append(piece.custom_lines + a_line)
        t.ends_of_print["time"].append(piece.time_elapsed_lines + a_line)
        carry = piece.carry
        del piece, view, st
    for blk in by_end:  # blocks the group began but did not finish
        if any(a < last for a, _ in spans[blk]):
            t.pending[blk] = pending[blk]
    t.carry = carry
    return t


def _verdict(scan: _Scan, tallies: list[_Tally], result: SpliceResult, regions, retract_length, n_out):
    """The groups' reductions, in file order, as one :class:`SpliceCheck` (check_splice's order)."""
    original, so, data = scan.original, scan.original.state, scan.data
    if any(t.short for t in tallies):
        return SpliceCheck([f"the output has {n_out} lines, fewer than the kept lines need"])
    kept_line = next((t.kept_line for t in tallies if t.kept_line), None)
    problems: list[str] = [kept_line] if kept_line else []
    first_bad: dict[str, str] = {}
    volume, away, ratio, outside, pending = {}, {}, {}, {}, {}
    for t in tallies:
        for k, v in t.first_bad.items():
            first_bad.setdefault(k, v)
        volume.update(t.volume)
        away.update(t.away)
        ratio.update(t.ratio)
        outside.update(t.outside)
        for blk, parts in t.pending.items():
            for s, q in enumerate(parts):
                pending.setdefault(blk, [[] for _ in parts])[s].extend(q)
    order = ["Z", "E mode", "positioning mode", "tool", "retraction", "firmware retraction", "logical E"]
    order += ["feedrate"] + [f"{c} ({w} of a kept extrusion)" for c in ("X", "Y") for w in ("end", "start")]
    problems += [first_bad[k] for k in order if k in first_bad]

    for blk in scan.spans:  # blocks read by several groups (and spans past the last piece: none in a
        if blk not in ratio:  # well-formed result)
            got = pending.get(blk, [[] for _ in scan.spans[blk]])
            mv = [np.concatenate(q) if q else np.zeros(0, EXTRUSION_DTYPE) for q in got]
            _block_checks(
                original, scan.reps[blk], mv, scan.volume_tol, scan.regions.get(blk),
                volume, away, ratio, outside,
            )
    problems += [volume[rep.block] for rep in result.blocks if rep.block in volume]
    ratio = {rep.block: ratio[rep.block] for rep in result.blocks}
    max_r = max(float(so.retracted.max(initial=0.0)), retract_length, 0.0) + 1e-4
    r_lo, r_hi = min(t.r_lo for t in tallies), max(t.r_hi for t in tallies)
    if any(t.seen_new for t in tallies) and (r_lo < -1e-4 or r_hi > max_r):
        problems.append(
            f"new lines retract {r_hi:.5f} mm / prime {-r_lo:.5f} mm beyond what "
            f"was retracted (the slicer never holds back more than {max_r:.5f} mm)"
        )
    back_line = next((t.back_line for t in tallies if t.back_line is not None), None)
    if back_line is not None:
        problems.append(
            f"output line {back_line[0] + 1} moves absolute E backwards without retracting: {back_line[1]!r}"
        )

    counts = {fam: sum(t.counts[fam] for t in tallies) for fam in FAMILIES}
    family = max(counts, key=lambda k: counts[k]) if any(counts.values()) else "none"
    slicer, _ = detect_slicer(data[:_HEAD])
    slicers = {slicer, original.dialect.slicer} - {"unknown"}
    if family != original.dialect.family or len(slicers) > 1:
        from loadpath.gcode.flavors import Dialect

        _, version = detect_slicer(data[:_HEAD])
        problems.append(f"dialect changed: {original.dialect} -> {Dialect(slicer, version, family)}")
    n_layers = counts.get(family, 0)
    if n_layers != len(original.layers):
        problems.append(f"{len(original.layers)} layers in the original, {n_layers} in the output")
    else:
        from loadpath.splice.verify import layer_features

        lines = [a for t in tallies for a in t.layer_lines[family]]
        starts = np.concatenate(lines) if lines else np.zeros(0, np.int64)
        ends = {
            k: np.concatenate([a for t in tallies for a in t.ends_of_print[k]]).tolist()
            for k in ("end", "custom", "time")
        }
        marks = Markers(end_lines=ends["end"], custom_lines=ends["custom"], time_elapsed_lines=ends["time"])
        last_x = max(t.last_x for t in tallies)
        xs = np.array([last_x] if last_x >= 0 else [], dtype=np.int64)
        print_end = _print_end(marks, family, starts, xs, n_out)
        fn: list[set[str]] = [set() for _ in range(n_layers)]
        pairs: dict[tuple[int, str], int] = {}
        before = 0
        for t in tallies:
            for (layer, name), line in t.pairs[family].items():
                if before + layer >= 0:
                    pairs.setdefault((before + layer, name), line)
            before += t.counts[family]
        for (layer, name), line in pairs.items():
            if line < print_end:
                fn[layer].add(name)
        gone = emptied_features(original, result)
        for k, (a, b) in enumerate(zip(layer_features(original), fn, strict=True)):
            if features_differ(a, b, gone[k]):
                problems.append(f"layer {k + 1}: feature types {sorted(a)} became {sorted(b)}")
                break

    # check 7 in the order of the regions given, as check_splice reports it
    problems += [away[blk] for blk in regions if blk in away]
    outside = {blk: outside[blk] for blk in regions if blk in outside}
    return SpliceCheck(problems, ratio, outside)


def _block_checks(
    original: Program,
    rep,
    mv: list[np.ndarray],
    volume_tol: float,
    region: Region | None,
    volume: dict[int, str],
    away: dict[int, str],
    ratio: dict[int, float],
    outside: dict[int, float],
) -> None:
    """Make checks 3 and 7 of one replaced block from its spans' extrusions (module docstring).

    ``mv``: one EXTRUSION_DTYPE array per span of the block, as
    :func:`~loadpath.splice.verify.check_splice` reads them; the results go into the four dicts.
    """
    b = original.block(rep.block)
    got = 0.0
    for m in mv:
        got += float(np.ascontiguousarray(m["e"]).sum())
    aim = b.e * rep.volume_scale
    ratio[rep.block] = volume_ratio(got, aim)
    if not abs(ratio[rep.block] - 1.0) <= volume_tol:
        volume[rep.block] = (
            f"block {rep.block} (layer {b.layer + 1}, {b.feature}): new infill extrudes "
            f"{got:.3f} mm of filament, the original {b.e:.3f} mm x {rep.volume_scale:.3f} "
            f"({ratio[rep.block]:.3f}x)"
        )
    if region is None:
        return
    pts, half = [], []
    for m in mv:
        for t in (0.0, 0.5, 1.0):
            pts.append(np.stack([m["x0"] + t * (m["x1"] - m["x0"]), m["y0"] + t * (m["y1"] - m["y0"])], 1))
            half.append(np.where(np.isfinite(m["width"]), m["width"], 0.4) / 2)
    if not pts:
        return
    pt = np.concatenate(pts)
    h = np.concatenate(half)
    shapely.prepare(region)
    d = np.zeros(len(pt))
    out = ~shapely.contains_xy(region, pt[:, 0], pt[:, 1])
    if out.any():
        d[out] = shapely.distance(region, shapely.points(pt[out]))
    outside[rep.block] = float(d.max(initial=0.0))
    bad = d > h + 1e-3
    if bad.any():
        k = int(np.argmax(d - h))
        away[rep.block] = (
            f"block {rep.block}: new extrusion at ({pt[k, 0]:.3f}, {pt[k, 1]:.3f}) lies {d[k]:.3f} mm "
            f"outside the replace region (more than half its bead width)"
        )
