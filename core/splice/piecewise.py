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

Pieces are cut only at the output's places of the original's layer markers (kept lines), between
its first and its last layer: no config block or thumbnail (the header's and the trailer's
multi-line marker blocks) spans a cut.  The config the machine state needs (volumetric E) is read
from the header and the trailer before the pieces.

(Over 300 lines, :func:`check_pieces` over 200: the seven checks of
:func:`~loadpath.splice.verify.check_splice`, each kept as a running reduction over the pieces; they
share the piece loop and its arrays, so they stay in one function, but for the per-block checks 3
and 7, :func:`_block_checks`.)
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import shapely
from loadpath._typing import Region
from loadpath.gcode.blocks import EXTRUDE, RETRACT, WIPE
from loadpath.gcode.flavors import detect_slicer
from loadpath.gcode.lines import check_text, index_lines
from loadpath.gcode.markers import Markers, read_markers
from loadpath.gcode.model import Program
from loadpath.gcode.parse import _HEAD, _print_end, _volumetric_area
from loadpath.gcode.words import G, tokenize
from loadpath.splice.lineview import EXTRUSION_DTYPE, FAMILIES, Carry, read_piece
from loadpath.splice.splicer import SpliceResult
from loadpath.splice.verify import SpliceCheck, first_difference, kept_state, state_value

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
):
    """:func:`~loadpath.splice.verify.check_splice` of ``data`` read piece by piece (module docstring).

    Returns
    -------
    SpliceCheck or None
        None when the output holds a G2/G3 arc (the caller parses it in full: its moves are arc
        chords) or when the original's first or last layer marker has no place in it (no cut is
        known to be safe: the caller reads it whole).
    """
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
    wanted = sorted({*cuts[1:], *marks})
    at = dict(zip(wanted, _line_offsets(data, wanted), strict=True))
    offsets = [0, *(at[j] for j in cuts[1:]), len(data)]
    cuts.append(n_out)
    area = _volumetric_area(_config(data, at[marks[0]], at[marks[1]]))
    so = original.state

    # the output's kept lines and where each block's new lines are
    i_k = np.flatnonzero(keep)
    j_k = lmap[i_k]
    edits = list(result.edits)
    out_start, shift = {}, 0
    for a, z, k in sorted(edits):
        out_start[(a, z)] = a + shift
        shift += k - (z - a)
    count = {(a, z): k for a, z, k in edits}
    spans: dict[int, list[tuple[int, int]]] = {}
    for rep in result.blocks:
        b = original.block(rep.block)
        ranges = [(b.span_start, b.span_stop)]
        if b.exit_start >= b.span_stop and b.exit_stop > b.exit_start:
            ranges.append((b.exit_start, b.exit_stop))
        spans[rep.block] = [(out_start[r], out_start[r] + count[r]) for r in ranges]
    pending = {blk: [[] for _ in sp] for blk, sp in spans.items()}  # extrusions per span, as read
    by_end = sorted(spans, key=lambda blk: max((z for _, z in spans[blk]), default=0))
    regions = regions or {}
    volume: dict[int, str] = {}  # check 3's problem per block
    away: dict[int, str] = {}  # check 7's
    ratio: dict[int, float] = {}
    outside: dict[int, float] = {}
    reps = {rep.block: rep for rep in result.blocks}

    motion = np.isin(so.cmd[i_k], (G + 0, G + 1, G + 2, G + 3))
    moving = np.isin(original.kind_of_line[i_k], (EXTRUDE, WIPE)) | np.isin(so.cmd[i_k], (G + 2, G + 3))
    first_bad: dict[str, str] = {}
    names: list[str] = []
    max_r = max(float(so.retracted.max(initial=0.0)), retract_length, 0.0) + 1e-4
    r_lo, r_hi, seen_new = np.inf, -np.inf, False
    back_line: tuple[int, str] | None = None
    kept_line: str | None = None
    counts = dict.fromkeys(FAMILIES, 0)
    layer_lines: dict[str, list[np.ndarray]] = {f: [] for f in FAMILIES}
    pairs: dict[str, dict[tuple[int, int], int]] = {f: {} for f in FAMILIES}  # (layer, feature) -> first line
    ends_of_print: dict[str, list[np.ndarray]] = {"end": [], "custom": [], "time": []}
    last_x = -1
    carry = Carry()
    prev_xy = (0.0, 0.0)

    for p in range(len(cuts) - 1):
        a_line, z_line = cuts[p], cuts[p + 1]
        piece = read_piece(data[offsets[p] : offsets[p + 1]], carry, names, area)
        view, st = piece.view, piece.view.state
        if view.n_lines != z_line - a_line:
            return SpliceCheck([f"the output has {n_out} lines, fewer than the kept lines need"])
        if view.arc_lines.any():
            return None

        # 1. kept lines byte for byte (the runs of kept lines in this piece)
        lo, hi = np.searchsorted(j_k, [a_line, z_line])
        if kept_line is None and hi > lo:
            ii, jj = i_k[lo:hi], j_k[lo:hi] - a_line
            brk = np.flatnonzero((np.diff(ii) != 1) | (np.diff(jj) != 1)) + 1
            for s, e in zip(np.r_[0, brk], np.r_[brk, len(ii)], strict=True):
                i0, i1, j0, j1 = int(ii[s]), int(ii[e - 1]) + 1, int(jj[s]), int(jj[e - 1]) + 1
                if original.lines_bytes(i0, i1) != view.lines_bytes(j0, j1):
                    bad = next(i for i in range(i0, i1) if original.line(i) != view.line(j0 + i - i0))
                    kept_line = (
                        f"kept line {bad + 1} changed: {original.line(bad)!r} -> "
                        f"{view.line(j0 + bad - i0)!r}"
                    )
                    break

        # 2. machine state on kept lines
        sel = slice(lo, hi)
        ik, jk = i_k[sel], j_k[sel] - a_line

        def differ(name, a, b, tol=0.0, mask=None, ik=ik):
            if name in first_bad:
                return
            k = first_difference(a, b, tol, mask)
            if k is not None:
                first_bad[name] = (
                    f"{name} differs after kept line {ik[k] + 1} ({original.line(int(ik[k]))!r}): "
                    f"{state_value(a[k])} in the original, {state_value(b[k])} in the output"
                )

        for name, a, b, tol, mask in kept_state(so, st, ik, jk, motion[sel]):
            differ(name, a, b, tol, mask)
        prev_o = np.maximum(ik - 1, 0)
        pj = np.maximum(j_k[sel] - 1, 0) - a_line  # -1: the previous piece's last line
        for axis, before in (("x", prev_xy[0]), ("y", prev_xy[1])):
            col = getattr(st, axis)
            end = f"{axis.upper()} (end of a kept extrusion)"
            differ(end, getattr(so, axis)[ik], col[jk], 1e-6, moving[sel])
            differ(
                f"{axis.upper()} (start of a kept extrusion)",
                getattr(so, axis)[prev_o],
                np.where(pj >= 0, col[np.maximum(pj, 0)], before),
                1e-6,
                moving[sel],
            )

        # 3, 7. each block's extrusions, gathered until its spans are read
        for blk, sp in spans.items():
            for s, (a, z) in enumerate(sp):
                if z > a_line and a < z_line:
                    pending[blk][s].append(
                        view.extrusions(max(a, a_line) - a_line, min(z, z_line) - a_line, prev_xy)
                    )
        while by_end and max((z for _, z in spans[by_end[0]]), default=0) <= z_line:
            blk = by_end.pop(0)
            mv = [np.concatenate(q) if q else np.zeros(0, EXTRUSION_DTYPE) for q in pending.pop(blk)]
            _block_checks(original, reps[blk], mv, volume_tol, regions.get(blk), volume, away, ratio, outside)

        # 4. retraction bounds in new lines; 5. absolute E backwards
        new_lines = np.ones(view.n_lines, dtype=bool)
        new_lines[jk] = False
        r_new = st.retracted[new_lines]
        if len(r_new):
            seen_new = True
            r_lo, r_hi = min(r_lo, float(r_new.min())), max(r_hi, float(r_new.max()))
        if back_line is None:
            ab = ~st.e_relative
            back = ab & (st.de < -1e-9) & ~np.isin(view.kind_of_line, (RETRACT, WIPE)) & (st.cmd != G + 92)
            if back.any():
                k = int(np.argmax(back))
                back_line = (a_line + k, view.line(k))

        # 6. layers and the features extruded in each, for every family of layer markers
        ext = np.flatnonzero(st.moved_xy & (st.de > 0))
        if len(ext):
            last_x = a_line + int(ext[-1])
        for fam in FAMILIES:
            local = piece.layer_lines[fam]
            layer = counts[fam] + np.searchsorted(local, ext, "right") - 1
            has = layer >= 0
            key = layer[has] * 65536 + view.feature_of_line[ext[has]].astype(np.int64) + 1
            uniq, first = np.unique(key, return_index=True)
            got = pairs[fam]
            for u, f in zip(uniq.tolist(), first.tolist(), strict=True):
                got.setdefault((u // 65536, u % 65536 - 1), a_line + int(ext[has][f]))
            counts[fam] += len(local)
            layer_lines[fam].append(local + a_line)
        ends_of_print["end"].append(piece.end_lines + a_line)
        ends_of_print["custom"].append(piece.custom_lines + a_line)
        ends_of_print["time"].append(piece.time_elapsed_lines + a_line)
        prev_xy = (float(st.x[-1]), float(st.y[-1])) if view.n_lines else prev_xy
        carry = piece.carry
        del piece, view, st

    problems: list[str] = [kept_line] if kept_line else []
    order = ["Z", "E mode", "positioning mode", "tool", "retraction", "firmware retraction", "logical E"]
    order += ["feedrate"] + [
        f"{c} ({w} of a kept extrusion)" for c in ("X", "Y") for w in ("end", "start")
    ]
    problems += [first_bad[k] for k in order if k in first_bad]

    for blk in by_end:  # spans past the last piece (none in a well-formed result)
        mv = [np.concatenate(q) if q else np.zeros(0, EXTRUSION_DTYPE) for q in pending.pop(blk)]
        _block_checks(original, reps[blk], mv, volume_tol, regions.get(blk), volume, away, ratio, outside)
    problems += [volume[rep.block] for rep in result.blocks if rep.block in volume]
    ratio = {rep.block: ratio[rep.block] for rep in result.blocks}
    if seen_new and (r_lo < -1e-4 or r_hi > max_r):
        problems.append(
            f"new lines retract {r_hi:.5f} mm / prime {-r_lo:.5f} mm beyond what "
            f"was retracted (the slicer never holds back more than {max_r:.5f} mm)"
        )
    if back_line is not None:
        problems.append(
            f"output line {back_line[0] + 1} moves absolute E backwards without retracting: {back_line[1]!r}"
        )

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

        starts = np.concatenate(layer_lines[family]) if family in layer_lines else np.zeros(0, np.int64)
        marks = Markers(
            end_lines=np.concatenate(ends_of_print["end"]).tolist(),
            custom_lines=np.concatenate(ends_of_print["custom"]).tolist(),
            time_elapsed_lines=np.concatenate(ends_of_print["time"]).tolist(),
        )
        xs = np.array([last_x] if last_x >= 0 else [], dtype=np.int64)
        print_end = _print_end(marks, family, starts, xs, n_out)
        fn: list[set[str]] = [set() for _ in range(n_layers)]
        for (layer, feat), line in pairs.get(family, {}).items():
            if line < print_end:
                fn[layer].add(names[feat] if feat >= 0 else "")
        for k, (a, b) in enumerate(zip(layer_features(original), fn, strict=True)):
            if a != b:
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
    ratio[rep.block] = got / aim if aim > 0 else float("nan")
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
