"""Feature blocks and their line spans, computed for the whole file with searchsorted.

A **block** is a maximal run of lines in one layer with one feature and one object that contains at
least one extrusion.  For the splicer (issue 6) each block has three half-open line ranges:

``start:stop`` (the core)
    From the lines that open it (its ``;TYPE:`` / ``;WIDTH:`` / ``M204`` / ``G1 F`` lines right before
    the first extrusion, i.e. neutral lines reached going back from the first extrusion) to its last
    extrusion, inclusive.
``span_start:span_stop`` (contiguous, never crossing a barrier line)
    The core plus the travel that enters it (lift, move, lower, unretract: written before the
    ``;TYPE:`` line) and the wipe/retraction that leaves it when that follows the last extrusion
    directly.  Replacing ``span_start:span_stop`` replaces the block with its way in and out.
``exit_start:exit_stop``
    The wipe/retraction that leaves the block, wherever it is: PrusaSlicer moves the wipe of a
    layer's last block behind the next layer's ``;LAYER_CHANGE ... G92 E0`` lines, so it can lie
    after barrier lines, outside the span.  Empty (``exit_start == exit_stop``) when there is none.

Every line gets a kind (:data:`KINDS`): extrusion, wipe (a move with negative E, or a wipe marker),
retract / unretract (E only, or ``G10``/``G11``), travel (any other move: XY travel, lift, lower),
neutral (comments that are not structure markers, feed-rate-only moves, ``M73``, ``M106``/``M107``,
``M117``, ``M201``-``M205``: lines a splicer may move to the block start), and barrier (everything
else: layer and object markers, ``G92``, mode changes, temperatures, tool changes, unknown commands).
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Ints
from loadpath.gcode.words import NO_COMMAND, M

__all__ = [
    "NEUTRAL",
    "EXTRUDE",
    "WIPE",
    "RETRACT",
    "UNRETRACT",
    "TRAVEL",
    "BARRIER",
    "KINDS",
    "BLOCK_DTYPE",
    "line_kinds",
    "find_blocks",
    "NEUTRAL_COMMANDS",
]

NEUTRAL, EXTRUDE, WIPE, RETRACT, UNRETRACT, TRAVEL, BARRIER = range(7)
KINDS = ("neutral", "extrude", "wipe", "retract", "unretract", "travel", "barrier")
"""Names of the line kinds, indexed by the kind code."""

NEUTRAL_COMMANDS = (M + 73, M + 106, M + 107, M + 117, M + 201, M + 203, M + 204, M + 205)
"""Commands a splicer may carry along: progress, fan, message, acceleration/jerk/feed limits."""

BLOCK_DTYPE = np.dtype(
    [
        ("layer", "i4"),  # index into Program.layers
        ("feature", "i2"),  # index into Program.features
        ("role", "i1"),  # loadpath.gcode.Role
        ("object", "i2"),  # index into Program.objects, -1 = none
        ("start", "i8"),  # core first line
        ("stop", "i8"),  # core end (last extrusion + 1)
        ("span_start", "i8"),
        ("span_stop", "i8"),
        ("exit_start", "i8"),
        ("exit_stop", "i8"),
        ("type_line", "i8"),  # line of the ;TYPE:/; FEATURE: marker naming the feature, -1 = none
        ("move_start", "i8"),  # rows of Program.moves with start <= line < stop
        ("move_stop", "i8"),
        ("e", "f8"),  # filament extruded, mm
        ("length", "f8"),  # extruded path length, mm
    ]
)


def line_kinds(
    cmd: np.ndarray,
    motion: np.ndarray,
    moved_xy: np.ndarray,
    de: np.ndarray,
    in_wipe: np.ndarray,
    wipe_marker: Ints,
    barrier_comment: Ints,
    fw_retract: np.ndarray,
    fw_unretract: np.ndarray,
    has_axes: np.ndarray,
) -> np.ndarray:
    """Kind code (:data:`KINDS`) of every line; see the module docstring."""
    n = len(cmd)
    kind = np.full(n, BARRIER, dtype=np.int8)
    kind[cmd == NO_COMMAND] = NEUTRAL
    m_code = cmd - M
    lut = np.zeros(1000, dtype=bool)
    lut[[c - M for c in NEUTRAL_COMMANDS]] = True
    kind[(m_code >= 0) & (m_code < 1000) & lut[np.clip(m_code, 0, 999)]] = NEUTRAL
    kind[motion & ~has_axes] = NEUTRAL  # G1 F8640
    kind[np.asarray(barrier_comment, dtype=np.int64)] = BARRIER
    mv = motion & has_axes
    kind[mv] = TRAVEL
    kind[mv & moved_xy & (de > 0)] = EXTRUDE
    kind[mv & moved_xy & ((de < 0) | (in_wipe & (de == 0)))] = WIPE
    kind[mv & ~moved_xy & (de < 0)] = RETRACT
    kind[mv & ~moved_xy & (de > 0)] = UNRETRACT
    kind[fw_retract] = RETRACT
    kind[fw_unretract] = UNRETRACT
    kind[np.asarray(wipe_marker, dtype=np.int64)] = WIPE
    return kind


def _kinds_in(kind: np.ndarray, wanted: tuple[int, ...]) -> np.ndarray:
    """Lines whose kind is one of ``wanted`` (a lookup table instead of ``np.isin``)."""
    lut = np.zeros(len(KINDS), dtype=bool)
    lut[list(wanted)] = True
    return np.flatnonzero(lut[kind])


def _last_before(sorted_lines: Ints, at: Ints) -> Ints:
    """Largest element of ``sorted_lines`` that is < ``at`` (-1 when none)."""
    if len(sorted_lines) == 0:
        return np.full(len(at), -1, dtype=np.int64)
    k = np.searchsorted(sorted_lines, at, side="left") - 1
    return np.where(k >= 0, sorted_lines[np.maximum(k, 0)], -1)


def _first_from(sorted_lines: Ints, at: Ints, default: int) -> Ints:
    """Smallest element of ``sorted_lines`` that is >= ``at`` (``default`` when none)."""
    if len(sorted_lines) == 0:
        return np.full(len(at), default, dtype=np.int64)
    k = np.searchsorted(sorted_lines, at, side="left")
    return np.where(k < len(sorted_lines), sorted_lines[np.minimum(k, len(sorted_lines) - 1)], default)


def find_blocks(
    kind: np.ndarray, layer: np.ndarray, feature: np.ndarray, obj: np.ndarray, type_marker_line: np.ndarray
) -> np.ndarray:
    """All blocks of the file as a :data:`BLOCK_DTYPE` array.

    ``move_*``, ``e``, ``length`` and ``role`` are left for the caller.

    Parameters
    ----------
    kind : (n_lines,) int8
        :func:`line_kinds`.
    layer, feature, obj : (n_lines,)
        Layer index (-1 outside layers), feature code and object code of every line.
    type_marker_line : (n_lines,) int64
        Line of the last feature marker at or before each line (-1 when none).
    """
    n = len(kind)
    out = np.zeros(0, dtype=BLOCK_DTYPE)
    if n == 0:
        return out
    change = np.ones(n, dtype=bool)
    change[1:] = (layer[1:] != layer[:-1]) | (feature[1:] != feature[:-1]) | (obj[1:] != obj[:-1])
    run = np.cumsum(change) - 1
    xl = np.flatnonzero((kind == EXTRUDE) & (layer >= 0))
    if len(xl) == 0:
        return out
    xrun = run[xl]
    first_of = np.ones(len(xl), dtype=bool)
    first_of[1:] = xrun[1:] != xrun[:-1]
    last_of = np.ones(len(xl), dtype=bool)
    last_of[:-1] = xrun[1:] != xrun[:-1]
    first_x = xl[first_of]
    last_x = xl[last_of]
    m = len(first_x)

    stop_enter = np.flatnonzero(kind != NEUTRAL)  # core start: go back over neutral lines only
    start = _last_before(stop_enter, first_x) + 1
    start = np.minimum(start, first_x)
    hard_enter = _kinds_in(kind, (EXTRUDE, WIPE, RETRACT, BARRIER))
    p = _last_before(hard_enter, start)
    tu = np.flatnonzero((kind == TRAVEL) | (kind == UNRETRACT))
    q = _first_from(tu, p + 1, n)
    span_start = np.where(q < start, q, start)

    stop = last_x + 1
    exit_hard = _kinds_in(kind, (EXTRUDE, TRAVEL, UNRETRACT))
    h = _first_from(exit_hard, stop, n)
    wr = np.flatnonzero((kind == WIPE) | (kind == RETRACT))
    f = _first_from(wr, stop, n)
    last_wr_before_h = _last_before(wr, h)
    has_exit = f < h
    exit_start = np.where(has_exit, f, stop)
    exit_stop = np.where(has_exit, last_wr_before_h + 1, stop)
    any_stop = _kinds_in(kind, (EXTRUDE, TRAVEL, UNRETRACT, BARRIER))
    b = _first_from(any_stop, stop, n)
    last_wr_before_b = _last_before(wr, b)
    span_stop = np.where(last_wr_before_b >= stop, last_wr_before_b + 1, stop)

    out = np.zeros(m, dtype=BLOCK_DTYPE)
    out["layer"] = layer[first_x]
    out["feature"] = feature[first_x]
    out["object"] = obj[first_x]
    out["start"] = start
    out["stop"] = stop
    out["span_start"] = span_start
    out["span_stop"] = span_stop
    out["exit_start"] = exit_start
    out["exit_stop"] = exit_stop
    out["type_line"] = type_marker_line[first_x]
    return out
