"""Machine state after every line, computed with numpy (forward fills and segmented sums).

Modal state is a forward fill of the lines that set it; positions are "last absolute value plus the
relative moves since", which is one cumulative sum per axis.  Semantics (``slicer-conventions.md`` §5):

- ``G90``/``G91`` switch X, Y, Z between absolute and relative; ``M82``/``M83`` latch the E mode.
  E moves are relative when ``M83`` is latched **or** ``G91`` is active; ``G90`` returns E to the
  latch.  This is what Prusa firmware, Klipper and PrusaSlicer's own G-code viewer do
  (``GCodeProcessor``: E is relative if global positioning or the E-local mode is relative).  Marlin 2
  instead lets ``G90`` reset E to absolute; slicers write ``M82``/``M83`` after ``G90``, so the
  two only differ on files that rely on that side effect.
- ``G92`` sets the logical position of the axes it names (all four to 0 without words); ``G28``
  homes the named axes (all without words) to 0.
- Feedrate ``F`` is modal across G0-G3; the first move's feedrate is NaN until an ``F`` is seen.
- ``G10``/``G11`` without other words are firmware retract/unretract.
- The initial position is (0, 0, 0), E = 0, absolute positioning and absolute E (firmware defaults).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from loadpath._typing import Bools, Floats, Ints
from loadpath.gcode.words import BIT, G, M, T, Tokens

__all__ = ["LineState", "Start", "ffill", "machine_state", "MOTION", "is_motion"]

MOTION = (G + 0, G + 1, G + 2, G + 3)
"""Commands that move the machine (and may extrude)."""


def is_motion(cmd: np.ndarray) -> np.ndarray:
    """``cmd`` is one of :data:`MOTION` (G0-G3)."""
    return (cmd >= G) & (cmd <= G + 3)


@dataclass(frozen=True)
class LineState:
    """Machine state **after** each line (arrays of length ``n_lines``).

    The state before line ``i`` is the state after line ``i - 1`` (the initial state for ``i = 0``,
    see :meth:`loadpath.gcode.Program.state_before`).

    Attributes
    ----------
    cmd : int32
        Command code (:mod:`loadpath.gcode.words`).
    x, y, z : float64, mm
        Logical position (``G92`` offsets applied as the firmware does).
    e : float64, file units
        E axis position as the firmware counts it (mm of filament, mm^3 with volumetric E); in relative
        mode it accumulates the relative moves since the last ``G92 E``.
    de : float64, mm of filament
        Filament pushed (> 0) or pulled (< 0) by this line, whatever the E mode.
    f : float64, mm/min
        Modal feedrate (NaN before the first ``F``).
    absolute_xyz : bool
        ``G90`` (True) or ``G91`` (False) in effect.
    e_relative : bool
        E words are relative (``M83`` latched or ``G91`` active).
    moved_xy : bool
        This line moved X or Y (or is an arc).
    fw_retracted : bool
        Firmware retraction (``G10``) in effect.
    retracted : float64, mm of filament
        Filament currently retracted by E moves: grows with retractions and wipes, shrinks with
        unretractions, reset to 0 by an extrusion (can go negative when an unretraction primes extra).
    tool : int16
        Active tool (``T<n>``), 0 before the first tool change.
    """

    cmd: np.ndarray
    x: Floats
    y: Floats
    z: Floats
    e: Floats
    de: Floats
    f: Floats
    absolute_xyz: Bools
    e_relative: Bools
    moved_xy: Bools
    fw_retracted: Bools
    retracted: Floats
    tool: np.ndarray
    sums: tuple[tuple[str, float, float, float], ...] = ()
    """Per summed register (``X Y Z E R``, R: retracted): the value set last, the running sum of
    additions at that set, and the running sum after the last line (what :class:`Start` carries)."""

    @cached_property
    def absolute_e_ahead(self) -> Bools:
        """``(n_lines,)`` bool: some line at or after each line runs in absolute E mode.

        There the logical E (:attr:`e`) is what the next absolute E word measures from, so a
        rewritten stretch of relative-E lines must leave it where the original did (CuraEngine's
        end code switches to ``M82`` after a relative-E print).
        """
        ahead = np.logical_or.accumulate(~self.e_relative[::-1])[::-1]
        return np.ascontiguousarray(ahead)


@dataclass(frozen=True)
class Start:
    """The machine state a run of lines starts from (a piece of a file read on its own).

    The defaults are the firmware's state before a file (module docstring); :meth:`after` gives the
    state after the last line of a piece, so the next piece continues where it ended.

    Attributes
    ----------
    x, y, z : float, mm
    e : float, file units
    f : float, mm/min
    absolute_xyz : bool
    e_latch_relative : bool
        ``M83`` latched (``M82``: False).
    fw_retracted : bool
    retracted : float, mm of filament
    tool : int
    """

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    e: float = 0.0
    f: float = float("nan")
    absolute_xyz: bool = True
    e_latch_relative: bool = False
    fw_retracted: bool = False
    retracted: float = 0.0
    tool: int = 0
    sums: tuple[tuple[str, float, float, float], ...] = ()

    def seg(self, name: str, initial: float) -> tuple[float, float, float]:
        """``(value set last, running sum at that set, running sum)`` of a summed register."""
        for k, sv, cj, c in self.sums:
            if k == name:
                return sv, cj, c
        return initial, 0.0, 0.0

    def after(self, st: LineState) -> Start:
        """Return the state after the last line of ``st`` (a piece that started from ``self``)."""
        if len(st.cmd) == 0:
            return self
        latch = np.flatnonzero((st.cmd == M + 83) | (st.cmd == M + 82))
        return Start(
            x=float(st.x[-1]),
            y=float(st.y[-1]),
            z=float(st.z[-1]),
            e=float(st.e[-1]),
            f=float(st.f[-1]),
            absolute_xyz=bool(st.absolute_xyz[-1]),
            e_latch_relative=bool(st.cmd[latch[-1]] == M + 83) if len(latch) else self.e_latch_relative,
            fw_retracted=bool(st.fw_retracted[-1]),
            retracted=float(st.retracted[-1]),
            tool=int(st.tool[-1]),
            sums=st.sums,
        )


def ffill(n: int, lines: Ints, values: np.ndarray, initial) -> np.ndarray:
    """Forward fill: ``out[i]`` is the value of the last event at or before line ``i``.

    Parameters
    ----------
    n : int
        Number of lines.
    lines : (k,) int, sorted
        Lines where the state is set (a later event on the same line wins).
    values : (k,) array
        The value set at each of those lines.
    initial : scalar
        Value before the first event.
    """
    values = np.asarray(values)
    table = np.concatenate([np.asarray([initial], dtype=values.dtype if len(values) else None), values])
    pick = np.zeros(n, dtype=np.int32 if len(values) < 2**31 - 1 else np.int64)
    if len(lines):
        pick[np.asarray(lines)] = np.arange(1, len(lines) + 1, dtype=pick.dtype)
        np.maximum.accumulate(pick, out=pick)
    return table[pick]


def _segmented(
    set_mask: Bools, set_val: Floats, add_val: Floats, initial: float, seg: tuple | None = None
) -> tuple[Floats, tuple[float, float, float]]:
    """Value after each line of a register that lines either set or add to, and what a next piece carries.

    ``value[i] = set_val[j] + sum(add_val[j+1..i])`` with ``j`` the last set at or before ``i``.
    Written as ``set_val[j] + (c[i] - c[j])`` so a set value comes back exactly when nothing was added.
    ``seg``: ``(value set last, running sum at that set, running sum)`` before the first line (default
    ``(initial, 0, 0)``); the running sum goes on from it one addition at a time, so a file read in
    pieces gets the very values of its whole read.  Returns the values and the same triple after
    the last line.
    """
    n = len(set_mask)
    sv, cj, c0 = seg if seg is not None else (initial, 0.0, 0.0)
    c = np.cumsum(add_val) if not c0 else np.cumsum(np.concatenate([[c0], add_val]))[1:]
    last = np.where(set_mask, np.arange(n), -1)
    np.maximum.accumulate(last, out=last)
    has = last >= 0
    j = np.where(has, last, 0)
    base = np.where(has, set_val[j], sv)
    since = np.where(has, c - c[j], c - cj)
    if n == 0:
        return base + since, (sv, cj, c0)
    k = int(last[-1])
    out = (float(set_val[k]), float(c[k]), float(c[-1])) if k >= 0 else (sv, cj, float(c[-1]))
    return base + since, out


def machine_state(
    tok: Tokens, arc_lines: Bools, volumetric_area: float | None = None, start: Start | None = None
) -> LineState:
    """Compute :class:`LineState` from the tokens (see the module docstring for the semantics).

    Parameters
    ----------
    tok : Tokens
    arc_lines : (n_lines,) bool
        Lines that are G2/G3 arcs (they move in XY even when they end where they started).
    volumetric_area : float or None, mm^2
        Filament cross-section when E is volumetric (``use_volumetric_e``): ``de`` is then E / area.
    start : Start, optional
        The state before the first line (default: the firmware's, :class:`Start`).  A piece of a file
        read from the state its previous piece ended in gets the same state as the whole file's
        read, but for the rounding of sums of relative moves (they restart at the piece).
    """
    s0 = start if start is not None else Start()
    cmd = tok.cmd
    n = len(cmd)
    v, present = tok.values, tok.present
    motion = is_motion(cmd)
    g92 = cmd == G + 92
    g28 = cmd == G + 28
    has = {c: (present & np.uint16(BIT[c])) != 0 for c in "XYZEF"}
    no_axes = ~(has["X"] | has["Y"] | has["Z"] | has["E"])

    def modal(on: Bools, off: Bools, initial: bool) -> Bools:
        ev = np.flatnonzero(on | off)
        return ffill(n, ev, on[ev], initial)

    absolute = modal(cmd == G + 90, cmd == G + 91, s0.absolute_xyz)
    e_latch_rel = modal(cmd == M + 83, cmd == M + 82, s0.e_latch_relative)
    e_rel = e_latch_rel | ~absolute

    pos = {}
    sums = []
    initial = {"X": s0.x, "Y": s0.y, "Z": s0.z}
    for c in "XYZ":
        mv = motion & has[c]
        set_mask = (mv & absolute) | (g92 & (has[c] | no_axes)) | (g28 & (has[c] | no_axes))
        set_val = np.where(mv | (g92 & has[c]), v[c], 0.0)
        rel = mv & ~absolute
        seg = s0.seg(c, initial[c])
        if rel.any():
            pos[c], seg = _segmented(set_mask, set_val, np.where(rel, v[c], 0.0), initial[c], seg)
        else:  # absolute positioning throughout: a forward fill
            ev = np.flatnonzero(set_mask)
            pos[c] = ffill(n, ev, set_val[ev], initial[c])
            if len(ev):  # nothing added: the running sum stands where it stood
                seg = (float(set_val[ev[-1]]), seg[2], seg[2])
        sums.append((c, *seg))
    me = motion & has["E"]
    e_set = (me & ~e_rel) | (g92 & (has["E"] | no_axes))
    e_set_val = np.where(me | (g92 & has["E"]), v["E"], 0.0)
    e_add = np.where(me & e_rel, v["E"], 0.0)
    e, seg = _segmented(e_set, e_set_val, e_add, s0.e, s0.seg("E", s0.e))
    sums.append(("E", *seg))
    e_before = np.concatenate([[s0.e], e[:-1]])
    de = np.where(me, np.where(e_rel, v["E"], v["E"] - e_before), 0.0)
    if volumetric_area:
        de = de / volumetric_area

    f_lines = np.flatnonzero(motion & has["F"])
    f = ffill(n, f_lines, v["F"][f_lines], s0.f)

    x_before = np.concatenate([[s0.x], pos["X"][:-1]])
    y_before = np.concatenate([[s0.y], pos["Y"][:-1]])
    moved_xy = motion & ((pos["X"] != x_before) | (pos["Y"] != y_before) | arc_lines)

    fw = (cmd == G + 10) | (cmd == G + 11)
    fw &= ~tok.other_words
    fw_ev = np.flatnonzero(fw)
    fw_retracted = ffill(n, fw_ev, cmd[fw_ev] == G + 10, s0.fw_retracted)

    # filament held back by E moves: extrusions reset it, retractions / wipes / unretractions add
    extrude = moved_xy & (de > 0)
    e_only = motion & ~moved_xy & (de != 0)
    wipe = moved_xy & (de < 0)
    retracted, seg = _segmented(
        extrude, np.zeros(n), np.where(e_only | wipe, -de, 0.0), s0.retracted, s0.seg("R", s0.retracted)
    )
    sums.append(("R", *seg))

    t_lines = np.flatnonzero((cmd >= T) & (cmd < T + 10_000))
    tool = ffill(n, t_lines, (cmd[t_lines] - T).astype(np.int16), np.int16(s0.tool))

    return LineState(
        cmd=cmd,
        x=pos["X"],
        y=pos["Y"],
        z=pos["Z"],
        e=e,
        de=de,
        f=f,
        absolute_xyz=absolute,
        e_relative=e_rel,
        moved_xy=moved_xy,
        fw_retracted=fw_retracted,
        retracted=retracted,
        tool=tool,
        sums=tuple(sums),
    )
