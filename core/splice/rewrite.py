"""Rewrite one feature block with new chains, leaving the machine as the next original line expects.

Called by :func:`loadpath.splice.splice` for each replaced block.  The block's lines
(``span_start:span_stop``, plus a detached leaving wipe ``exit_start:exit_stop``; see
:mod:`loadpath.gcode.blocks`) are rewritten as follows (``slicer-conventions.md`` §5):

entering part (``span_start:start``)
    Lift, lower and unretract lines are kept verbatim (they do not depend on XY); the XY travel is
    replaced by a travel to the first new chain.  If the original did not retract but the new travel
    has to (it leaves the region, or is longer than ``retract_before_travel``), the travel gets its
    own retraction, lift and unretraction.
core (``start:stop``)
    Moves, feature/width/height markers, ``G1 F`` lines and ``G92 E`` lines are dropped; every other
    line (``M204``, fan, temperature, comments) is kept in order at the block start; ``M73`` progress
    lines are spread over the new block at the same fraction of its printed length.  Then the new
    chains, with the family's markers (``;TYPE:`` the replaced block's own feature name, ``;WIDTH:``
    when the width changes, ``;HEIGHT:``), joined by travels that retract, wipe and lift the way the
    slicer is set up to.
leaving part (``stop:span_stop`` and the detached exit)
    Wipe moves are regenerated backwards along the new last chain, with the same total E (the same
    retraction); retraction lines and markers are kept verbatim (in absolute E mode after a ``G92 E``
    that puts E where the original had it, when the new chains' plastic ended elsewhere).
afterwards
    ``;WIDTH:``/``;HEIGHT:`` re-emitted as the original had them, Z and feedrate restored,
    ``G92 E<original>`` where the logical E matters (absolute E mode, or absolute E further on), and
    a travel back to the original end point when the next original move depends on the position (an
    extrusion, a relative or partial move, an arc), or was made where the slicer's nozzle stood
    (CuraEngine's infill wipe and layer change; that travel follows the slicer's retraction rules
    and combing, :func:`~loadpath.splice.travel.travel`).
emptied (no chains)
    A block whose unit's runs all print in its siblings' blocks (:func:`_emptied`): every move of
    its span goes (the travel in, the lift, the prime, the wipe and retraction out) with its
    markers; its other lines stay, and the machine is left as above, retracted as the original was.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from loadpath._typing import Points2, Region
from loadpath.gcode.blocks import BARRIER, EXTRUDE, NEUTRAL, RETRACT, TRAVEL, UNRETRACT, WIPE
from loadpath.gcode.model import Block, Program
from loadpath.gcode.rowindex import move_rows
from loadpath.gcode.words import G, M, T
from loadpath.splice.arcfit import ArcOptions, fit_arcs
from loadpath.splice.emit import Style, Writer, fmt, width_changes
from loadpath.splice.plan import BlockPlan, Chain
from loadpath.splice.travel import (
    Motion,
    TravelState,
    cover_travels,
    prepare_wipes,
    travel,
    unretract,
    wipe_back,
    wipe_distance,
)

__all__ = ["Rewritten", "rewrite_block", "refusal"]

MARK_STEP, MARK_HYSTERESIS = 0.001, 0.0005
"""Width markers of the new chains (mm): widths rounded to ``MARK_STEP`` and a marker at every change
of at least ``MARK_HYSTERESIS`` (bead runs have one width each, :mod:`loadpath.splice.beadruns`); the
block's precomputed :func:`~loadpath.splice.emit.width_changes` and :meth:`Writer.extrude_many` read
the same two."""

_MOTION_RE = re.compile(r"^\s*G([0-3])(?![0-9.])([^;]*)", re.I)
_WORD_RE = re.compile(r"([XYZEF])\s*[-+.0-9]", re.I)
_G92_E_ONLY = re.compile(r"^\s*G92(\s+E\s*[-+.0-9]+)?\s*(;.*)?$", re.I)
_M73 = re.compile(r"^\s*M73\b", re.I)
_REFUSE_CMDS = {G + 90: "G90", G + 91: "G91", M + 82: "M82", M + 83: "M83", G + 28: "G28"}


def refusal(program: Program, b: Block) -> str | None:
    """Why a block must be kept as it is (mode or tool change inside its lines), else None."""
    for a, z in b.spans:
        cmd = program.state.cmd[a:z]
        for code, name in _REFUSE_CMDS.items():
            if np.any(cmd == code):
                return f"{name} inside the block changes the machine mode"
        if np.any((cmd >= T) & (cmd < T + 10_000)):
            return "a tool change inside the block"
        for i in np.flatnonzero(cmd == G + 92):
            if not _G92_E_ONLY.match(program.line(a + int(i))):
                return "G92 on X/Y/Z inside the block"
    return None


def _sets_f(text: str) -> bool:
    m = _MOTION_RE.match(text)
    return bool(m) and any(w.upper() == "F" for w in _WORD_RE.findall(m.group(2)))


STOOD_MM = 1.0
"""A non-extruding move after a replaced block that moved the slicer's nozzle less than this (mm)
was made where the nozzle stood (:func:`_next_move`)."""


def _next_move(program: Program, after: int) -> str:
    """How the next XY-moving original line from ``after`` on depends on the nozzle position.

    ``"position"``: it does (an extrusion, an arc, a relative or partial move).  ``"stood"``: it is
    an absolute move that extrudes nothing and moved the slicer's nozzle less than :data:`STOOD_MM`:
    a move made where the nozzle stood, such as CuraEngine's infill wipe (a 0.04 mm ``G1`` past the
    last line, ``infill_wipe_dist``, at print speed) or its layer change (``G0 F600 X.. Y.. Z..`` at
    the position it is at); from the new paths' end it would cross the part at that speed, primed.
    ``""``: neither (a travel, or no move): it goes from wherever the nozzle is.
    """
    s = program.state
    for j in range(after, program.n_lines):
        cmd = int(s.cmd[j])
        if cmd not in (G + 0, G + 1, G + 2, G + 3):
            continue
        m = _MOTION_RE.match(program.line(j))
        if not m:
            continue
        words = {x.upper() for x in _WORD_RE.findall(m.group(2))}
        if not ({"X", "Y"} & words) and cmd in (G + 0, G + 1):
            continue  # Z, E or F only: position-independent
        if (
            cmd in (G + 2, G + 3)
            or not bool(s.absolute_xyz[j])
            or not {"X", "Y"} <= words
            or float(s.de[j]) != 0.0
        ):
            return "position"
        moved = float(np.hypot(s.x[j] - s.x[j - 1], s.y[j] - s.y[j - 1])) if j > 0 else math.inf
        return "stood" if moved < STOOD_MM else ""
    return ""


def returns_to(program: Program, b: Block) -> Points2 | None:
    """Where the nozzle must travel back to after block ``b``'s new lines before the slicer's next
    move, ``(2,)`` mm, when that move was made where the nozzle stood (:func:`_next_move`:
    CuraEngine's infill wipe and layer change), else None.  The block's order weighs the travel to
    there (:func:`loadpath.splice.plan.plan_block`'s ``end``)."""
    end = b.exit_stop if b.detached_exit else b.span_stop
    if _next_move(program, end) != "stood":
        return None
    s = program.state
    return np.array([float(s.x[end - 1]), float(s.y[end - 1])])


def _marker_lines(style: Style) -> tuple[str, ...]:
    out = [style.feature]
    out += [p for p in (style.width, style.height, ";TYPE:", ";WIDTH:", ";HEIGHT:") if p]
    return tuple(p.strip() for p in out)


def _dropped(p: Program, i: int, markers: tuple[str, ...]) -> bool:
    """Whether line ``i`` of a rewritten block goes although it moves nothing: a feature, width or
    height marker (``markers``), a feedrate-only ``G0``/``G1`` (the new lines set their own) or a
    ``G92 E`` (the logical E is restored where it matters)."""
    text = p.line(i)
    cmd = int(p.state.cmd[i])
    return (
        text.strip().startswith(markers)
        or (cmd in (G + 0, G + 1) and bool(_MOTION_RE.match(text)))
        or (cmd == G + 92 and bool(_G92_E_ONLY.match(text)))
    )


def _exit_writer(p: Program, b: Block, at: Writer, style: Style, volumetric_area: float | None) -> Writer:
    """A writer for block ``b``'s detached exit: the original's state before it, at ``at``'s position."""
    e0 = p.state_before(b.exit_start)
    w2 = Writer(style, at.x, at.y, e0.z, e0.e, e0.f, e0.e_relative, volumetric_area)
    w2.width, w2.height = e0.width, e0.height
    w2.retracted = e0.retracted
    return w2


def _width_text(v: float) -> str:
    return fmt(v, 6, True)


def _verbatim(w: Writer, st: TravelState, i: int) -> None:
    """Copy original line ``i`` and apply its (position-independent) effect to the writer."""
    p = st.program
    s = p.state
    text = p.line(i)
    prev = i - 1
    if (
        prev >= 0
        and not bool(s.e_relative[i])
        and int(s.cmd[i]) in (G + 0, G + 1, G + 2, G + 3)
        and round(w.e, 5) != round(float(s.e[prev]), 5)
    ):
        # absolute E: the copied line's E is a target that means the original's move (a retraction of
        # 0.8 mm) only from the original's E; new paths whose plastic differs end elsewhere
        w.set_e(float(s.e[prev]))
    w.raw(text)
    dz = float(s.z[i] - (s.z[prev] if prev >= 0 else 0.0))
    de = float(s.e[i] - (s.e[prev] if prev >= 0 else 0.0))
    w.z += dz
    if s.cmd[i] == G + 92:
        w.e = w._e_exact = float(s.e[i])
    else:
        w.e += de
        w._e_exact += de
    w.retracted += float(s.retracted[i] - (s.retracted[prev] if prev >= 0 else 0.0))
    st.fw = bool(s.fw_retracted[i])
    if _sets_f(text):
        w.f = float(s.f[i])
    mv = p.moves[move_rows(p, i, i + 1)]
    if len(mv):
        d = np.sqrt((mv["z1"] - mv["z0"]) ** 2 + (mv["x1"] - mv["x0"]) ** 2 + (mv["y1"] - mv["y0"]) ** 2)
        d = np.where(d > 0, d, np.abs(mv["e"]))
        ok = np.isfinite(mv["f"]) & (mv["f"] > 0)
        w.seconds += float(np.sum(d[ok] / mv["f"][ok]) * 60.0)


# ---------------------------------------------------------------------------------------------- block


@dataclass
class Rewritten:
    """Text of a rewritten block: the span and, when detached, the exit."""

    span: str
    exit: str | None
    n_travels: int
    n_retracts: int
    end_xy: tuple[float, float]
    seconds: float


def _core_fraction(program: Program, b: Block) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative extruded length fraction after each core line (for placing M73 lines)."""
    mv = program.moves[b.moves]
    seg = np.where(mv["extrude"], np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"]), 0.0)
    cum = np.cumsum(seg)
    total = cum[-1] if len(cum) and cum[-1] > 0 else 1.0
    return mv["line"], cum / total


def _leaving(w: Writer, st: TravelState, a: int, z: int, last: Points2) -> None:
    """Lines ``[a, z)`` of a leaving wipe/retraction: wipe moves regenerated, the rest verbatim."""
    p = st.program
    kind = p.kind_of_line
    wipes = [i for i in range(a, z) if kind[i] == WIPE and p.state.moved_xy[i]]
    total = -float(np.sum(p.state.de[wipes])) if wipes else 0.0
    rows = move_rows(p, a, z)
    mv = p.moves[rows]
    mv = mv[mv["wipe"]]
    dist = float(np.sum(np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"])))
    w._carry = 0.0
    for i in range(a, z):
        if wipes and i == wipes[0]:
            if _sets_f(p.line(i)):
                w.feed(float(p.state.f[i]))
            pulled = wipe_back(w, last, dist, total)
            if pulled < total - 1e-12:  # no path to wipe along: the same retraction without moving
                w.e_move(-(total - pulled), float(p.state.f[i]))
        elif i in wipes:
            continue
        else:
            _verbatim(w, st, i)


def _restore(w: Writer, st: TravelState, end: int, style: Style, keep_position: bool = False) -> None:
    """Leave the machine as the original was after line ``end - 1``.

    The position too, unless ``keep_position`` (a detached wipe continues from here).
    """
    p = st.program
    s = p.state
    i = end - 1
    if style.width and not math.isnan(p.width_of_line[i]) and w.width != float(p.width_of_line[i]):
        w.marker(style.width, _width_text(float(p.width_of_line[i])))
    if style.height and not math.isnan(p.height_of_line[i]) and w.height != float(p.height_of_line[i]):
        w.marker(style.height, _width_text(float(p.height_of_line[i])))
    away = abs(w.x - s.x[i]) > 1e-6 or abs(w.y - s.y[i]) > 1e-6
    how = _next_move(p, end) if not keep_position and away else ""
    if how == "position":
        w.travel(float(s.x[i]), float(s.y[i]), st.motion.travel_f)
    elif how == "stood":  # a travel as the slicer travels (its retraction rules, combing), primed at the end
        travel(w, st, np.array([float(s.x[i]), float(s.y[i])]), None)
    if abs(w.z - float(s.z[i])) > 1e-9:
        w.z_move(float(s.z[i]), st.motion.lift_f)
    if not math.isnan(s.f[i]) and (math.isnan(w.f) or abs(w.f - float(s.f[i])) > 1e-9):
        w.feed(float(s.f[i]))
    # absolute E: the next E word measures from here; relative E: the same once the file switches
    # to absolute E further on (CuraEngine's end code: M82), else the logical E is nobody's concern
    if bool(s.absolute_e_ahead[i]) and round(w.e, 5) != round(float(s.e[i]), 5):
        w.set_e(float(s.e[i]))


def rewrite_block(
    program: Program,
    b: Block,
    plan: BlockPlan,
    region: Region | None,
    motion: Motion,
    style: Style,
    volumetric_area: float | None,
    arcs: ArcOptions | None = None,
    comb: Region | None = None,
) -> Rewritten:
    """Write the new text of one block (see the module docstring).

    Parameters
    ----------
    program : Program
    b : Block
    plan : BlockPlan
        The new chains (may be empty: the block is then only removed, the machine state kept).
    region : shapely geometry or None
        Replace region: travels that leave it always retract.
    motion : Motion
    style : Style
    volumetric_area : float or None
        Filament cross-section when E words are mm^3.
    arcs : ArcOptions or None
        Write runs of segments that lie on a circle as ``G2``/``G3`` (:mod:`loadpath.splice.arcfit`;
        only where the file allows arcs).
    comb : shapely geometry or None
        The island's part outline: a travel from the slicer's walls into the region (or back) may
        cross them inside it (:func:`~loadpath.splice.travel.route`).
    """
    p = program
    s = p.state
    s0 = p.state_before(b.span_start)
    layer_z = float(s.z[b.stop - 1])
    w = Writer(style, s0.x, s0.y, s0.z, s0.e, s0.f, s0.e_relative, volumetric_area)
    w.width = s0.width
    w.height = s0.height
    st = TravelState(p, region, motion, layer_z, comb)
    st.fw = s0.fw_retracted
    w.retracted = s0.retracted
    chains = plan.chains
    if not chains:
        return _emptied(w, st, b, style, volumetric_area)
    first = chains[0].points[0]

    # entering part
    travelled = False
    kind = p.kind_of_line
    for i in range(b.span_start, b.start):
        if kind[i] == TRAVEL and s.moved_xy[i]:
            if not travelled:
                z = float(s.z[i]) if s.z[i] != (s.z[i - 1] if i > 0 else 0.0) else None
                f = float(s.f[i]) if _sets_f(p.line(i)) else None
                travel(w, st, first, None, f, z)
            travelled = True
            continue
        _verbatim(w, st, i)

    # core: kept lines first, M73 spread, then the chains
    markers = _marker_lines(style)
    lines, frac = _core_fraction(p, b)
    m73: list[tuple[float, str]] = []
    # only the neutral and barrier lines are read (moves and the rest are dropped unread)
    core = b.start + np.flatnonzero((kind[b.start : b.stop] == NEUTRAL) | (kind[b.start : b.stop] == BARRIER))
    for i in core.tolist():
        k = kind[i]
        text = p.line(i)
        if _dropped(p, i, markers):
            continue
        if k == NEUTRAL:
            if _M73.match(text):
                j = int(np.searchsorted(lines, i, "left")) - 1
                m73.append((float(frac[j]) if j >= 0 else 0.0, text))
                continue
            w.raw(text)
        elif k == BARRIER:
            w.raw(text)
    if not travelled:
        travel(w, st, first, None)
    if w.retracted > 1e-9 or st.fw:
        unretract(w, st)
    w.marker(style.feature, b.feature)
    h = float(p.height_of_line[b.stop - 1])
    if style.height and not math.isnan(h):
        w.marker(style.height, _width_text(h))
        w.height = h
    w.width = math.nan  # the first chain states its width
    total_len = sum(c.length for c in chains) or 1.0
    done_len = 0.0
    m73.sort(key=lambda t: t[0])
    mi = 0
    last: Points2 | None = None
    if len(chains) > 1:  # the travels between chains, from one's end to the next one's start
        ends = np.array([c.points[-1] for c in chains[:-1]])
        cover_travels(st, ends, np.array([c.points[0] for c in chains[1:]]))
        r = motion.retraction
        if r.wipe and not r.firmware and r.length > 0 and r.speed > 0:  # the wipes they may take
            prepare_wipes(st, [c.points for c in chains[:-1]], wipe_distance(motion), style.leading_zero)
    # the chains' width changes and times in one pass each (Writer.extrude_many's, the same figures)
    changes: list = [None] * len(chains)
    sizes = [len(c.width) for c in chains]
    if style.width:
        widths = np.concatenate([c.width for c in chains])
        changes = width_changes(widths, sizes, MARK_STEP, MARK_HYSTERESIS)
    ratio = np.concatenate([c.segments for c in chains]) / np.maximum(
        np.concatenate([c.feedrate for c in chains]), 1e-9
    )
    bounds = np.cumsum([0, *sizes]).tolist()
    secs = [float(np.sum(ratio[a:z]) * 60.0) for a, z in zip(bounds[:-1], bounds[1:], strict=True)]
    for ci, c in enumerate(chains):
        if ci > 0:
            travel(w, st, c.points[0], last, last_length=chains[ci - 1].length)
            if w.retracted > 1e-9 or st.fw:
                unretract(w, st)
        mi, done_len = _extrude_chain(w, c, style, m73, mi, done_len, total_len, arcs, changes[ci], secs[ci])
        last = c.points
    for _, text in m73[mi:]:
        w.raw(text)

    # leaving part
    exit_detached = b.detached_exit
    if b.span_stop > b.stop:
        _leaving(w, st, b.stop, b.span_stop, last if last is not None else np.array([[w.x, w.y]] * 2))
    end_xy = (w.x, w.y)
    if not exit_detached:
        _restore(w, st, b.span_stop, style)
        return Rewritten(w.text(_nl(p)), None, st.n_travels, st.n_retracts, end_xy, w.seconds)
    _restore(w, st, b.span_stop, style, keep_position=True)
    span_text = w.text(_nl(p))
    # detached exit: start from the original state there, at our position
    w2 = _exit_writer(p, b, w, style, volumetric_area)
    st.fw = bool(s.fw_retracted[b.exit_start - 1])  # the exit follows the block: never line 0
    _leaving(w2, st, b.exit_start, b.exit_stop, last if last is not None else np.array([[w.x, w.y]] * 2))
    _restore(w2, st, b.exit_stop, style)
    return Rewritten(span_text, w2.text(_nl(p)), st.n_travels, st.n_retracts, end_xy, w.seconds + w2.seconds)


_MOVES = (EXTRUDE, WIPE, RETRACT, UNRETRACT, TRAVEL)


def _emptied(w: Writer, st: TravelState, b: Block, style: Style, volumetric_area: float | None) -> Rewritten:
    """The text of a block left without a chain: its lines but the moves and markers, then the
    machine as the original left it after the block (its retraction too: the prime in and the
    retraction out are gone with the moves).  With a detached exit, the lines between the span and
    the exit (barriers: an object's end label) find the machine retracted already."""
    p = st.program
    last = (b.exit_stop if b.detached_exit else b.span_stop) - 1
    _unmoved(w, st, b.span_start, b.span_stop, style)
    _retracted_as(w, st, last)
    if not b.detached_exit:
        _restore(w, st, b.span_stop, style)
        return Rewritten(w.text(_nl(p)), None, st.n_travels, st.n_retracts, (w.x, w.y), w.seconds)
    _restore(w, st, b.span_stop, style, keep_position=True)
    span_text = w.text(_nl(p))
    w2 = _exit_writer(p, b, w, style, volumetric_area)
    w2.retracted = float(p.state.retracted[last])  # as _retracted_as left it, not as the original was
    _unmoved(w2, st, b.exit_start, b.exit_stop, style)
    _restore(w2, st, b.exit_stop, style)
    secs = w.seconds + w2.seconds
    return Rewritten(span_text, w2.text(_nl(p)), st.n_travels, st.n_retracts, (w.x, w.y), secs)


def _unmoved(w: Writer, st: TravelState, a: int, z: int, style: Style) -> None:
    """Lines ``[a, z)`` but their moves, feature, width, height and wipe markers and ``G92 E``."""
    p = st.program
    kind = p.kind_of_line
    markers = _marker_lines(style) + tuple(m.strip() for m in (style.wipe_start, style.wipe_end) if m)
    for i in range(a, z):
        if kind[i] not in _MOVES and not _dropped(p, i, markers):
            _verbatim(w, st, i)


def _retracted_as(w: Writer, st: TravelState, line: int) -> None:
    """Retract or prime (or ``G10``/``G11``) so the filament stands as the original's after ``line``."""
    s = st.program.state
    r = st.motion.retraction
    if bool(s.fw_retracted[line]) != st.fw:
        w.raw("G10" if bool(s.fw_retracted[line]) else "G11")
        st.fw = bool(s.fw_retracted[line])
        return
    more = float(s.retracted[line]) - w.retracted
    if more > 1e-9:
        w.e_move(-more, r.speed * 60.0)
    elif more < -1e-9:
        w.e_move(-more, (r.deretract_speed or r.speed) * 60.0)
    w.retracted = float(s.retracted[line])


def _nl(p: Program) -> str:
    return p.newline.decode("ascii")


def _extrude_chain(
    w: Writer,
    c: Chain,
    style: Style,
    m73: list[tuple[float, str]],
    mi: int,
    done_len: float,
    total_len: float,
    arcs: ArcOptions | None = None,
    changes: tuple[list[int], list[float]] | None = None,
    seconds: float | None = None,
) -> tuple[int, float]:
    """Write one chain: width markers where the rounded width changes, feedrate, E; M73 lines on the way.

    ``changes``, ``seconds``: the chain's width changes and time made for the block at once
    (:meth:`Writer.extrude_many`'s), for a chain written in one piece.
    """
    seg = c.segments
    cum = done_len + np.cumsum(seg)
    inserts: dict[int, list[str]] = {}
    while mi < len(m73) and m73[mi][0] * total_len <= cum[-1] + 1e-9:
        k = int(np.searchsorted(cum, m73[mi][0] * total_len - 1e-9))
        inserts.setdefault(min(k, len(seg) - 1), []).append(m73[mi][1])
        mi += 1
    # runs have one width each (loadpath.splice.beadruns): a marker at every change (MARK_STEP)
    found = fit_arcs(c.points, c.filament, c.width, c.feedrate, arcs) if arcs is not None else []
    if not found:
        w.extrude_many(
            c.points, c.filament, c.feedrate, c.width, MARK_STEP, MARK_HYSTERESIS,
            inserts=inserts, seg=seg, changes=changes, seconds=seconds,
        )
        return mi, float(cum[-1])
    # lines between the arcs as one chain each, the arcs one move each; M73 lines after the piece
    # holding their segment
    at = 0
    for arc in [*found, None]:
        stop = arc.first if arc is not None else len(seg)
        if stop > at:
            sub = {k - at: v for k, v in inserts.items() if at <= k < stop}
            w.extrude_many(
                c.points[at : stop + 1], c.filament[at:stop], c.feedrate[at:stop], c.width[at:stop],
                MARK_STEP, MARK_HYSTERESIS, inserts=sub, seg=seg[at:stop],
            )
        if arc is None:
            break
        a, z = arc.first, arc.stop
        x, y = (float(v) for v in c.points[z])
        de = float(np.sum(c.filament[a:z]))
        w.arc(x, y, arc.centre, arc.ccw, de, float(c.feedrate[a]), float(c.width[a]))
        for k in range(a, z):
            for line in inserts.get(k, ()):
                w.raw(line)
        at = z
    return mi, float(cum[-1])
