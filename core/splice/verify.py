"""Check a spliced file against the original: what must hold for the printer to print it as intended.

:func:`check_splice` re-reads nothing itself: it takes the original :class:`Program`, the parsed output
and the :class:`~loadpath.splice.SpliceResult`, and returns a :class:`SpliceCheck` whose
``problems`` list is empty when

1. every line outside the replaced ranges is byte for byte the original line, in order;
2. every kept line runs in the same machine state as before: Z, feedrate of kept moves, E mode,
   positioning mode, tool, retraction (mm held back, firmware retraction), logical E in absolute
   mode, and the start and end point of every kept extrusion, wipe and arc;
3. per replaced block, the filament the output extrudes in the block's new lines is within
   ``volume_tol`` of what the slicer extruded there (read back from the written text);
4. new lines never prime more than was retracted, nor retract more than the slicer ever does;
5. absolute E never goes backwards except on retraction and wipe moves (and ``G92``);
6. the output has the same dialect, layers, and per-layer feature types as the original;
7. (given the replace regions) no new extrusion lies outside its block's region by more than half
   its bead width.

The pipeline runs it before writing anything, so a file that fails is never written, through
:func:`check_output`: the same checks from the output's bytes, read into the per-line arrays they
compare (:mod:`loadpath.splice.lineview`) instead of a whole second :class:`Program` (on an 842k-line
input whose output has 4.6M lines, that Program's parse peaked at 1.8 GB), and piece by piece
(:mod:`loadpath.splice.piecewise`: a few hundred thousand lines at a time, not the whole output).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import shapely
from loadpath._typing import Region
from loadpath.gcode.blocks import EXTRUDE, RETRACT, WIPE
from loadpath.gcode.model import Program
from loadpath.gcode.rowindex import move_rows
from loadpath.gcode.words import G
from loadpath.splice.lineview import LineView, read_lines
from loadpath.splice.splicer import SpliceResult

__all__ = ["SpliceCheck", "check_splice", "check_output", "layer_features"]


@dataclass(frozen=True)
class SpliceCheck:
    """Result of :func:`check_splice`.

    Attributes
    ----------
    problems : list of str
        One line each; empty when everything holds.
    volume_ratio : dict of int -> float
        Per replaced block: filament extruded by its new lines / filament of the original block.
    outside_mm : dict of int -> float
        Per block with a region: largest distance of a new extrusion point outside the region, mm.
    """

    problems: list[str] = field(default_factory=list)
    volume_ratio: dict[int, float] = field(default_factory=dict)
    outside_mm: dict[int, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when there is no problem."""
        return not self.problems


def layer_features(program: Program) -> list[set[str]]:
    """Feature names that extrude, per layer."""
    m = program.moves
    ext = m[m["extrude"] & (m["layer"] >= 0)]
    out: list[set[str]] = [set() for _ in program.layers]
    for layer, feat in set(zip(ext["layer"].tolist(), ext["feature"].tolist(), strict=True)):
        out[layer].add(program.features[feat] if feat >= 0 else "")
    return out


def check_output(
    original: Program,
    data: bytes,
    result: SpliceResult,
    volume_tol: float = 0.03,
    regions: Mapping[int, Region] | None = None,
    retract_length: float = 0.0,
    piece_lines: int | None = None,
    workers: int = 1,
    groups: int | None = None,
) -> SpliceCheck:
    """:func:`check_splice` on the output's bytes, without parsing them into a :class:`Program`.

    The output is read and checked in pieces of about ``piece_lines`` lines
    (:func:`loadpath.splice.piecewise.check_pieces`, default
    :data:`~loadpath.splice.piecewise.PIECE_LINES`; 0: in one piece), or else whole into a
    :class:`~loadpath.splice.lineview.LineView` (the same parse stages, the same arrays, a third
    of the memory at its peak); an output with G2/G3 arcs is parsed in full, since its moves are arc
    chords.  Same parameters and result as :func:`check_splice`, with the output's bytes in place
    of its Program; ``workers`` and ``groups`` as for :func:`~loadpath.splice.piecewise.check_pieces`
    (groups of pieces read side by side).
    """
    from loadpath.splice.piecewise import PIECE_LINES, check_pieces

    lines = PIECE_LINES if piece_lines is None else piece_lines
    if lines > 0 and len(original.layers) >= 2:
        got = check_pieces(
            original, data, result, volume_tol, regions, retract_length, lines, workers, groups
        )
        if got is not None:
            return got
    view = read_lines(data)
    if view.arc_lines.any():
        from loadpath.gcode import parse

        del view
        output: Program | LineView = parse(data, strict=False)
    else:
        output = view
    return check_splice(original, output, result, volume_tol, regions, retract_length)


def _extrusions(output: Program | LineView, start: int, stop: int) -> np.ndarray:
    """Extruding moves of output lines ``[start, stop)``: fields ``x0 y0 x1 y1 e width``."""
    if isinstance(output, LineView):
        return output.extrusions(start, stop)
    mv = output.moves[move_rows(output, start, stop)]
    return mv[mv["extrude"]]


def volume_ratio(got: float, aim: float) -> float:
    """A replaced block's new filament over what it aims at (mm over mm).  A block that aims at none
    (a unit's runs all printed in a sibling, :func:`loadpath.pipeline.paths.share_volume`) must lay
    none: 1.0 when it lays none, else inf."""
    if aim > 0:
        return got / aim
    return 1.0 if got <= 1e-9 else float("inf")


def first_difference(a: np.ndarray, b: np.ndarray, tol: float = 0.0, mask: np.ndarray | None = None) -> int | None:
    """Index of the first entry where ``a`` and ``b`` (n,) differ by more than ``tol`` (NaN equal to
    NaN; only where ``mask``), or None."""
    bad = np.abs(a - b) > tol if tol else a != b
    if a.dtype.kind == "f":
        bad &= ~(np.isnan(a) & np.isnan(b))
    if mask is not None:
        bad &= mask
    return int(np.argmax(bad)) if bad.any() else None


def state_value(x: object) -> str:
    """A machine-state value as a problem line shows it: ``0.8``, ``True``, not ``np.float64(0.800001)``."""
    v = x.item() if isinstance(x, np.generic) else x
    return f"{v:.6g}" if isinstance(v, float) else repr(v)


def parked_lines(original: Program, result: SpliceResult) -> np.ndarray:
    """Which original lines lie between an emptied block's span and its detached exit, ``(n_lines,)`` bool.

    An emptied block (no new path: its unit's runs print in a sibling block,
    :func:`loadpath.pipeline.paths.share_volume`) neither primes nor wipes; the lines between its
    span and its leaving retraction (barriers: an object's end label) find the filament retracted
    where the original had just extruded.  They move nothing, so their retraction is not compared.
    """
    out = np.zeros(original.n_lines, dtype=bool)
    for rep in _emptied(result):
        b = original.block(rep.block)
        if b.detached_exit:
            out[b.span_stop : b.exit_start] = True
    return out


def emptied_features(original: Program, result: SpliceResult) -> list[set[str]]:
    """Per layer, the features of its emptied blocks (:func:`parked_lines`): a layer may lose such a
    feature type, its region printed by a sibling block's runs under the sibling's feature name."""
    out: list[set[str]] = [set() for _ in original.layers]
    for rep in _emptied(result):
        if 0 <= rep.layer < len(out):
            out[rep.layer].add(rep.feature)
    return out


def _emptied(result: SpliceResult) -> list:
    """The reports of the blocks emptied by design: aiming at no plastic, and laying none."""
    return [rep for rep in result.blocks if rep.volume_scale == 0 and rep.filament_new == 0]


def features_differ(before: set[str], after: set[str], emptied: set[str]) -> bool:
    """Whether a layer's feature types changed beyond losing some of its emptied blocks' ones."""
    return before != after and not (after <= before and before - after <= emptied)


def kept_state(
    so, sn, i_k: np.ndarray, j_k: np.ndarray, motion: np.ndarray, parked: np.ndarray | None = None
):
    """The machine state a kept line must see in the output as in the original, one field at a time.

    Parameters
    ----------
    so, sn : MachineState
        Of the original and of the output (or of a piece of it).
    i_k, j_k : (k,) int
        The kept lines' indices in each.
    motion : (k,) bool
        Which kept lines are moves (their feedrate counts).
    parked : (k,) bool, optional
        Kept lines whose retraction is not compared (:func:`parked_lines`).

    Yields
    ------
    (name, original values, output values, tolerance, mask or None)
    """
    yield "Z", so.z[i_k], sn.z[j_k], 1e-6, None
    yield "E mode", so.e_relative[i_k], sn.e_relative[j_k], 0.0, None
    yield "positioning mode", so.absolute_xyz[i_k], sn.absolute_xyz[j_k], 0.0, None
    yield "tool", so.tool[i_k], sn.tool[j_k], 0.0, None
    free = None if parked is None or not parked.any() else ~parked
    yield "retraction", so.retracted[i_k], sn.retracted[j_k], 1e-4, free
    yield "firmware retraction", so.fw_retracted[i_k], sn.fw_retracted[j_k], 0.0, free
    yield "logical E", so.e[i_k], sn.e[j_k], 2e-5, ~so.e_relative[i_k]
    yield "feedrate", so.f[i_k], sn.f[j_k], 1e-6, motion


def check_splice(
    original: Program,
    output: Program | LineView,
    result: SpliceResult,
    volume_tol: float = 0.03,
    regions: Mapping[int, Region] | None = None,
    retract_length: float = 0.0,
) -> SpliceCheck:
    """Check a splice (see the module docstring).

    Parameters
    ----------
    original : Program
    output : Program or LineView
        The output parsed (:func:`loadpath.gcode.parse`) or read for the check (:func:`check_output`).
    result : SpliceResult
    volume_tol : float
        Largest accepted relative difference of a block's extruded filament.
    regions : mapping of block -> region, optional
        Replace regions; enables check 7.
    retract_length : float, mm
        The retraction the splicer was told to use (new lines may hold back this much even when the
        file itself never did).

    (Over 120 lines: one walk over the replaced blocks and the untouched lines, each check adding a
    line to the problems.)
    """
    problems: list[str] = []
    n = original.n_lines
    lmap = result.line_map(n)
    keep = lmap >= 0
    if int(lmap.max(initial=-1)) >= output.n_lines:
        return SpliceCheck([f"the output has {output.n_lines} lines, fewer than the kept lines need"])
    # 1. kept lines byte for byte
    cuts = sorted({0, n, *(a for a, _, _ in result.edits), *(z for _, z, _ in result.edits)})
    runs = [(a, z) for a, z in zip(cuts[:-1], cuts[1:], strict=True) if z > a and keep[a]]
    for a, z in runs:
        if original.lines_bytes(a, z) != output.lines_bytes(int(lmap[a]), int(lmap[z - 1]) + 1):
            bad = next(i for i in range(a, z) if original.line(i) != output.line(int(lmap[i])))
            problems.append(
                f"kept line {bad + 1} changed: {original.line(bad)!r} -> {output.line(int(lmap[bad]))!r}"
            )
            break
    # 2. machine state on kept lines
    i_k = np.flatnonzero(keep)
    j_k = lmap[i_k]
    so, sn = original.state, output.state

    def differ(
        name: str, a: np.ndarray, b: np.ndarray, tol: float = 0.0, mask: np.ndarray | None = None
    ) -> None:
        k = first_difference(a, b, tol, mask)
        if k is not None:
            problems.append(
                f"{name} differs after kept line {i_k[k] + 1} ({original.line(int(i_k[k]))!r}): "
                f"{state_value(a[k])} in the original, {state_value(b[k])} in the output"
            )

    motion = np.isin(so.cmd[i_k], (G + 0, G + 1, G + 2, G + 3))
    for name, a, b, tol, mask in kept_state(so, sn, i_k, j_k, motion, parked_lines(original, result)[i_k]):
        differ(name, a, b, tol, mask)
    moving = np.isin(original.kind_of_line[i_k], (EXTRUDE, WIPE)) | np.isin(so.cmd[i_k], (G + 2, G + 3))
    prev_o, prev_n = np.maximum(i_k - 1, 0), np.maximum(j_k - 1, 0)
    for axis in ("x", "y"):
        differ(
            f"{axis.upper()} (end of a kept extrusion)",
            getattr(so, axis)[i_k],
            getattr(sn, axis)[j_k],
            1e-6,
            mask=moving,
        )
        differ(
            f"{axis.upper()} (start of a kept extrusion)",
            getattr(so, axis)[prev_o],
            getattr(sn, axis)[prev_n],
            1e-6,
            mask=moving,
        )
    # 3. volume per block, read back from the output
    ratio = {}
    edits = list(result.edits)
    out_start, shift = {}, 0
    for a, z, k in sorted(edits):
        out_start[(a, z)] = a + shift
        shift += k - (z - a)
    spans: dict[int, list[tuple[int, int]]] = {}
    for rep in result.blocks:
        b = original.block(rep.block)
        ranges = b.spans
        count = {(a, z): k for a, z, k in edits}
        spans[rep.block] = [(out_start[r], out_start[r] + count[r]) for r in ranges]
        got = 0.0
        for a, z in spans[rep.block]:
            got += float(np.ascontiguousarray(_extrusions(output, a, z)["e"]).sum())
        aim = b.e * rep.volume_scale  # the user's sparse fill may differ from the slicer's
        ratio[rep.block] = volume_ratio(got, aim)
        if not abs(ratio[rep.block] - 1.0) <= volume_tol:
            problems.append(
                f"block {rep.block} (layer {b.layer + 1}, {b.feature}): new infill extrudes "
                f"{got:.3f} mm of filament, the original {b.e:.3f} mm x {rep.volume_scale:.3f} "
                f"({ratio[rep.block]:.3f}x)"
            )
    # 4. retraction bounds in new lines
    new_lines = np.ones(output.n_lines, dtype=bool)
    new_lines[j_k] = False
    max_r = max(float(so.retracted.max(initial=0.0)), retract_length, 0.0) + 1e-4
    r_new = sn.retracted[new_lines]
    if len(r_new) and (r_new.min() < -1e-4 or r_new.max() > max_r):
        problems.append(
            f"new lines retract {r_new.max():.5f} mm / prime {-r_new.min():.5f} mm beyond what "
            f"was retracted (the slicer never holds back more than {max_r:.5f} mm)"
        )
    # 5. absolute E goes back only by retraction
    ab = ~sn.e_relative
    back = ab & (sn.de < -1e-9) & ~np.isin(output.kind_of_line, (RETRACT, WIPE)) & (sn.cmd != G + 92)
    if back.any():
        k = int(np.argmax(back))
        problems.append(
            f"output line {k + 1} moves absolute E backwards without retracting: {output.line(k)!r}"
        )
    # 6. dialect, layers, features
    slicers = {output.dialect.slicer, original.dialect.slicer} - {"unknown"}  # a .bgcode's text names none
    if output.dialect.family != original.dialect.family or len(slicers) > 1:
        problems.append(f"dialect changed: {original.dialect} -> {output.dialect}")
    n_out = output.n_layers if isinstance(output, LineView) else len(output.layers)
    if n_out != len(original.layers):
        problems.append(f"{len(original.layers)} layers in the original, {n_out} in the output")
    else:
        fo = layer_features(original)
        fn = output.layer_features() if isinstance(output, LineView) else layer_features(output)
        for k, (a, b, gone) in enumerate(zip(fo, fn, emptied_features(original, result), strict=True)):
            if features_differ(a, b, gone):
                problems.append(f"layer {k + 1}: feature types {sorted(a)} became {sorted(b)}")
                break
    # 7. inside the regions
    outside = {}
    for block, region in (regions or {}).items():
        if block not in spans or region is None:
            continue
        pts, half = [], []
        for a, z in spans[block]:
            mv = _extrusions(output, a, z)
            for t in (0.0, 0.5, 1.0):
                pts.append(
                    np.stack([mv["x0"] + t * (mv["x1"] - mv["x0"]), mv["y0"] + t * (mv["y1"] - mv["y0"])], 1)
                )
                half.append(np.where(np.isfinite(mv["width"]), mv["width"], 0.4) / 2)
        if not pts:
            continue
        p = np.concatenate(pts)
        h = np.concatenate(half)
        shapely.prepare(region)
        d = np.zeros(len(p))
        out = ~shapely.contains_xy(region, p[:, 0], p[:, 1])  # distance only for points outside
        if out.any():
            d[out] = shapely.distance(region, shapely.points(p[out]))
        outside[block] = float(d.max(initial=0.0))
        bad = d > h + 1e-3
        if bad.any():
            k = int(np.argmax(d - h))
            problems.append(
                f"block {block}: new extrusion at ({p[k, 0]:.3f}, {p[k, 1]:.3f}) lies {d[k]:.3f} mm "
                f"outside the replace region (more than half its bead width)"
            )
    return SpliceCheck(problems, ratio, outside)
