"""Writing G-code the way the slicer that made the file writes it: numbers, word order, markers.

:class:`Style` holds what differs between the marker families (``slicer-conventions.md`` §2-§4):

===========  ====================  ==========================  ===============================
family       travel                extrusion                   markers
===========  ====================  ==========================  ===============================
prusa        ``G1 X.. Y.. F10800`` ``G1 F4800`` then           ``;TYPE:`` ``;WIDTH:`` ``;HEIGHT:``
                                   ``G1 X.. Y.. E.03085``      ``;WIPE_START`` ``;WIPE_END``
bambu        same                  same                        ``; FEATURE:`` ``; LINE_WIDTH:``
                                                               ``; LAYER_HEIGHT:`` ``; WIPE_START``
cura         ``G0 F7200 X.. Y..``  ``G1 F3600 X.. Y.. E..``    ``;TYPE:`` only
===========  ====================  ==========================  ===============================

PrusaSlicer drops the leading zero (``Z.6``, ``E-.04``) and trailing zeros; Cura keeps the leading
zero.  XYZ are written with 3 decimals, E with 5, F with up to 3; the new extrusion moves of a
splice may take fewer (:attr:`Style.path_xy_decimals`, :attr:`Style.e_decimals`, issue 17: every
vertex but a chain's last, every relative E word but a chain's last).

:class:`Writer` accumulates lines and tracks the machine state it leaves (position, E, feedrate,
retraction).  E is written in the file's mode: relative values carry their rounding error to the next
move, absolute values are the rounded running total, so the sum written equals the sum asked for.
:meth:`Writer.extrude_many` keeps its chains (:class:`_Chains`) and works out only the state they
leave; their E words, feedrate changes and text are made for all of a writer's chains at once
when its lines are read (issue 17: per chain, numpy's fixed cost outweighed a chain's work).

(Over 400 lines: the writer, its deferred chains and their one-pass text share the E and feedrate
rules, which must stay the same figures call by call and in the one pass.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from loadpath.splice import numtext as nt

__all__ = ["Style", "STYLES", "Writer", "fmt", "fmt_few", "fmt_many", "width_changes"]


def fmt(value: float, decimals: int, leading_zero: bool = False) -> str:
    """Format a number as slicers write it: fixed decimals, trailing zeros dropped.

    Examples
    --------
    >>> fmt(0.6, 3), fmt(-0.04, 5), fmt(199.3680001, 3), fmt(0.0, 5), fmt(0.8, 3, leading_zero=True)
    ('.6', '-.04', '199.368', '0', '0.8')
    """
    s = f"{value:.{decimals}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    if s in ("-0", ""):
        s = "0"
    if not leading_zero:
        if s.startswith("0."):
            s = s[1:]
        elif s.startswith("-0."):
            s = "-" + s[2:]
    return s


@lru_cache(maxsize=1 << 16)
def fmt_few(value: float, decimals: int, leading_zero: bool = False) -> str:
    """:func:`fmt` remembered: for the words that take few values in a file (F, Z, ``;WIDTH:``).

    The splice of the 1000-layer specimen formatted 1.5 million numbers one at a time, most of them
    feedrates and widths seen before (issue 17).  Values that compare equal give the same text
    (``0.0`` and ``-0.0`` both ``"0"``), so a remembered text is the one :func:`fmt` writes.
    """
    return fmt(value, decimals, leading_zero)


def fmt_many(values, decimals: int, leading_zero: bool = False) -> list[str]:
    """Format many numbers as :func:`fmt` does (one pass of C-level string methods per value).

    Examples
    --------
    >>> fmt_many([0.6, -0.04, 199.3680001, 0.0, 100.0, -0.0001], 3)
    ['.6', '-.04', '199.368', '0', '100', '0']
    """
    f = f"%.{decimals}f"
    out = [(f % v).rstrip("0").rstrip(".") for v in np.asarray(values, dtype=float).tolist()]
    out = ["0" if s in ("-0", "") else s for s in out]
    if not leading_zero:
        out = [s[1:] if s[:2] == "0." else "-" + s[2:] if s[:3] == "-0." else s for s in out]
    return out


@dataclass(frozen=True)
class Style:
    """How one marker family writes moves and markers (see the module docstring).

    Attributes
    ----------
    family : {"prusa", "bambu", "cura"}
    travel_cmd : str
        ``"G1"`` or ``"G0"``.
    f_first : bool
        F is the first word of a move (Cura) instead of the last (PrusaSlicer travel).
    feed_line : bool
        A feedrate change before extrusions is its own ``G1 F..`` line (PrusaSlicer).
    leading_zero : bool
    feature, width, height : str or None
        Marker prefixes (None: the family has no such marker).
    wipe_start, wipe_end : str or None
    path_xy_decimals : int
        Decimals of X and Y in the new extrusion moves (:meth:`Writer.extrude_many`); travels,
        wipes and copied lines keep the slicer's 3.
    e_decimals : int
        Decimals of relative E words (absolute E keeps 5: the logical E a kept line sees must match
        the slicer's to 2e-5 mm).
    """

    family: str
    travel_cmd: str
    f_first: bool
    feed_line: bool
    leading_zero: bool
    feature: str
    width: str | None
    height: str | None
    wipe_start: str | None
    wipe_end: str | None
    path_xy_decimals: int = 3
    e_decimals: int = 5


STYLES = {
    "prusa": Style(
        "prusa", "G1", False, True, False, ";TYPE:", ";WIDTH:", ";HEIGHT:", ";WIPE_START", ";WIPE_END"
    ),
    "bambu": Style(
        "bambu",
        "G1",
        False,
        True,
        False,
        "; FEATURE: ",
        "; LINE_WIDTH: ",
        "; LAYER_HEIGHT: ",
        "; WIPE_START",
        "; WIPE_END",
    ),
    "cura": Style("cura", "G0", True, False, True, ";TYPE:", None, None, None, None),
}


class Writer:
    """Accumulates G-code lines and the machine state they leave.

    Parameters
    ----------
    style : Style
    x, y, z : float, mm
        Position the lines start from.
    e : float, file units
        Logical E the lines start from (what the firmware counts).
    f : float, mm/min
        Modal feedrate in effect (NaN: unknown).
    e_relative : bool
        E words are relative (``M83``).
    volumetric_area : float or None, mm^2
        Set when E words are mm^3: filament millimetres are multiplied by it when written.
    """

    def __init__(
        self,
        style: Style,
        x: float,
        y: float,
        z: float,
        e: float,
        f: float,
        e_relative: bool,
        volumetric_area: float | None = None,
    ) -> None:
        self.style = style
        self._lines: list = []  # str, or a _Chain of extrusion lines made on first read
        # extrude_many's moves not yet written
        self._pending = _Chains(e_relative, style.e_decimals if e_relative else 5)
        self.x, self.y, self.z = x, y, z
        self.e = e  # logical E after the last line written (rounded as written)
        self._e_exact = e  # running total as asked for (absolute mode)
        self._carry = 0.0  # rounding carry (relative mode)
        self.f = f
        self.e_relative = e_relative
        self.scale = volumetric_area or 1.0
        self.retracted = 0.0  # filament mm held back by this writer's retractions
        self.filament = 0.0  # filament mm pushed by extrusions (positive moves with XY)
        self.seconds = 0.0  # kinematic time of the moves written (distance / feedrate, no acceleration)
        self.width = math.nan  # ;WIDTH: in effect (as the viewer reads it)
        self.height = math.nan  # ;HEIGHT: in effect
        # decimals of E words: the style's in relative mode, the slicer's 5 in absolute mode
        self.e_dec = style.e_decimals if e_relative else 5

    # ------------------------------------------------------------------ numbers

    def _n(self, v: float, decimals: int = 3) -> str:
        return fmt(v, decimals, self.style.leading_zero)

    def _e_word(self, de_filament: float, exact: bool = False) -> str | None:
        """E word for ``de`` mm of filament; None when it rounds to nothing.

        ``exact``: a retraction, wipe or prime in relative E, written to the slicer's 5 decimals and
        kept out of the extrusions' rounding carry (what is pulled back is primed again exactly).
        """
        de = de_filament * self.scale
        if self.e_relative and exact and self.e_dec != 5:
            val = round(de, 5)
            if val == 0.0:
                return None
            self.e = self.e + val
            return "E" + fmt(val, 5, self.style.leading_zero)
        if self.e_relative:
            self._carry += de
            val = round(self._carry, self.e_dec)
            if val == 0.0:
                return None
            self._carry -= val
            self.e = self.e + val
            return "E" + fmt(val, self.e_dec, self.style.leading_zero)
        self._e_exact += de
        val = round(self._e_exact, 5)
        if val == round(self.e, 5):
            return None
        self.e = val
        return "E" + fmt(val, 5, self.style.leading_zero)

    def _f_word(self, f: float | None) -> str | None:
        if f is None or (not math.isnan(self.f) and abs(f - self.f) < 1e-9):
            return None
        self.f = f
        return "F" + fmt_few(f, 3, True)

    # ------------------------------------------------------------------ lines

    def raw(self, line: str) -> None:
        """Append a line as is (no state change)."""
        self._lines.append(line)

    def marker(self, prefix: str | None, value: str) -> None:
        """Append a marker comment (nothing when the family has no such marker)."""
        if prefix is not None:
            self._lines.append(f"{prefix}{value}")

    def feed(self, f: float) -> None:
        """Set the feedrate with its own line (``G1 F4800``) when it changes."""
        w = self._f_word(f)
        if w is not None:
            self._lines.append(f"G1 {w}")

    def _move(self, cmd: str, words: list[str], f: float | None, dist: float = 0.0) -> None:
        fw = self._f_word(f)
        if fw is not None:
            words = [fw, *words] if self.style.f_first else [*words, fw]
        self._lines.append(" ".join([cmd, *words]))
        if dist > 0 and self.f > 0:
            self.seconds += dist / self.f * 60.0

    def _dist(self, x: float, y: float) -> float:
        return math.hypot(x - self.x, y - self.y)

    def travel(self, x: float, y: float, f: float, z: float | None = None) -> None:
        """Move without extruding to ``(x, y[, z])`` at feedrate ``f`` (mm/min)."""
        words = [f"X{self._n(x)}", f"Y{self._n(y)}"]
        if z is not None:
            words.append(f"Z{self._n(z)}")
            self.z = z
        self._move(self.style.travel_cmd, words, f, self._dist(x, y))
        self.x, self.y = x, y

    def extrude(self, x: float, y: float, de: float, f: float | None = None) -> None:
        """Extrude ``de`` mm of filament (> 0) along a straight line to ``(x, y)``."""
        words = [f"X{self._n(x)}", f"Y{self._n(y)}"]
        ew = self._e_word(de)
        if ew is not None:
            words.append(ew)
        if f is not None and self.style.feed_line and not (not math.isnan(self.f) and abs(f - self.f) < 1e-9):
            self.feed(f)
            f = None
        self._move("G1", words, f, self._dist(x, y))
        self.x, self.y = x, y
        self.filament += de
        self.retracted = 0.0

    def arc(
        self, x: float, y: float, centre, ccw: bool, de: float, f: float, width: float | None = None
    ) -> None:
        """Extrude ``de`` mm of filament along an arc to ``(x, y)`` about ``centre`` (``G3`` if ``ccw``).

        ``G2``/``G3 X.. Y.. I.. J.. E..``, the centre as the offset from where the nozzle is
        (:mod:`loadpath.splice.arcfit`); a width marker first where ``width`` (mm, to 0.001)
        differs from the one stated; the feedrate as :meth:`extrude` writes it.  The time counts
        the chord (the arc is a little longer).
        """
        if width is not None and self.style.width:
            wq = round(width / 0.001) * 0.001
            if not abs(wq - self.width) < 0.0005:
                self._lines.append(f"{self.style.width}{fmt_few(wq, 6, True)}")
                self.width = wq
        words = [
            f"X{self._n(x)}",
            f"Y{self._n(y)}",
            f"I{self._n(centre[0] - self.x)}",
            f"J{self._n(centre[1] - self.y)}",
        ]
        ew = self._e_word(de)
        if ew is not None:
            words.append(ew)
        if self.style.feed_line and not (not math.isnan(self.f) and abs(f - self.f) < 1e-9):
            self.feed(f)
            f = None
        self._move("G3" if ccw else "G2", words, f, self._dist(x, y))
        self.x, self.y = x, y
        self.filament += de
        self.retracted = 0.0

    def extrude_many(
        self,
        points,
        de,
        f,
        widths=None,
        width_marker_step: float = 0.01,
        width_hysteresis: float = 0.0199,
        inserts: dict[int, list[str]] | None = None,
        seg=None,
        changes: tuple[list[int], list[float]] | None = None,
        seconds: float | None = None,
    ) -> None:
        """Extrude along a polyline in one go (the vectorized form of :meth:`extrude`).

        Parameters
        ----------
        points : (n + 1, 2) float, mm
            The polyline; the nozzle is at ``points[0]``.
        de : (n,) float, mm
            Filament per segment.
        f : (n,) float, mm/min
            Feedrate per segment.
        widths : (n,) float, mm, optional
            Bead width per segment: a width marker is written where it changes by a step.
        width_marker_step : float, mm
            Widths are rounded to this for the markers.
        width_hysteresis : float, mm
            A new width marker is written when the rounded width moved this far from the last one
            (viewers colour by it; the flow itself follows every segment's width exactly).
        inserts : dict of int -> list of str, optional
            Lines written after segment ``k`` (``M73`` progress lines).
        seg : (n,) float, mm, optional
            The segments' lengths, when the caller has them (else measured here).
        changes : (list of int, list of float), optional
            Where the rounded width (``widths`` rounded to ``width_marker_step``) differs from the
            segment before's (the first segment included) and that width, when the caller made them
            for many chains at once (:func:`width_changes`); else made here.
        seconds : float, s, optional
            The moves' kinematic time, ``np.sum(seg / np.maximum(f, 1e-9)) * 60``, when the caller has
            it.  Both are ignored where vertices are merged (``Style.path_xy_decimals`` below 3).
        """
        pts = np.asarray(points, dtype=float)
        de = np.asarray(de, dtype=float)
        if self.scale != 1.0:
            de = de * self.scale
        f = np.asarray(f, dtype=float)
        if self.style.path_xy_decimals < 3 and len(de) > 1:
            pts, de, f, widths, inserts, seg = _merge_unmoved(
                pts, de, f, widths, inserts, seg, self.style.path_xy_decimals
            )
            changes = seconds = None
        n = len(de)
        if n == 0:
            return
        # E: only the state after the chain here; the E words of all the writer's chains are made
        # in one pass when the lines are read (_Chains.e_words, the same figures)
        cs = np.cumsum(de)
        if self.e_relative:
            e0, e_prev = self._carry, 0.0
            c = self._carry + cs[-1:]
            r = np.round(c, 5)  # a chain's last E word to 5 decimals (_Chains.moves)
            self._carry = float(c[0] - r[0])
            self.e += float(r[0])
        else:
            e0, e_prev = self._e_exact, round(self.e, 5)
            c = self._e_exact + cs[-1:]
            r = np.round(c, 5)
            self._e_exact = float(c[0])
            self.e = float(r[0])
        # width markers (with hysteresis) before segments, at their place now: they set the state
        cur_w = self.width
        marks: list[tuple[int, float]] = []
        if widths is not None and self.style.width:
            if changes is None:
                changes = width_changes(widths, [len(de)], width_marker_step, width_hysteresis)[0]
            marks = _width_marks(*changes, cur_w, width_hysteresis)
            if marks:
                cur_w = marks[-1][1]
        fcur = self.f
        self._pending.add(pts[1:], de, cs, e0, e_prev, f, fcur if np.isfinite(fcur) else -1.0)
        self._lines.append(_Chain(len(self._pending.sizes) - 1, marks, inserts))
        if seconds is None:
            if seg is None:
                seg = np.hypot(*(pts[1:] - pts[:-1]).T)
            seconds = float(np.sum(seg / np.maximum(f, 1e-9)) * 60.0)
        self.seconds += seconds
        self.width = cur_w
        self.f = float(f[-1])
        self.x, self.y = float(pts[-1, 0]), float(pts[-1, 1])
        self.filament += float(np.sum(de)) / self.scale
        self.retracted = 0.0

    def wipe_many(self, points, de) -> None:
        """Move to each of ``points`` in turn while pulling filament back, ``de[k]`` on the way to the k-th.

        One ``G1 X Y E`` line per point (no E word where the pull rounds to nothing), the coordinates
        formatted in one pass (:func:`fmt_many`); E, time and retraction accumulate point by point.

        Parameters
        ----------
        points : (k, 2) float, mm
        de : (k,) float, mm of filament (> 0)
        """
        pts = np.asarray(points, dtype=float)
        lz = self.style.leading_zero
        xs, ys = pts[:, 0].tolist(), pts[:, 1].tolist()
        de_list = np.asarray(de, dtype=float).tolist()
        self.wipe_lines(xs, ys, fmt_many(xs, 3, lz), fmt_many(ys, 3, lz), de_list)

    def wipe_lines(self, xs: list, ys: list, xw: list, yw: list, de: list) -> None:
        """:meth:`wipe_many` with its points' coordinates ``xs, ys`` (float) and their text ``xw, yw``
        (:func:`fmt_many`, 3 decimals, the style's leading zero) given, ``de`` a list of floats."""
        lines = self._lines
        for x, y, d, xt, yt in zip(xs, ys, de, xw, yw, strict=True):
            ew = self._e_word(-d, exact=True)
            lines.append(f"G1 X{xt} Y{yt} {ew}" if ew is not None else f"G1 X{xt} Y{yt}")
            dist = math.hypot(x - self.x, y - self.y)
            if dist > 0 and self.f > 0:
                self.seconds += dist / self.f * 60.0
            self.x, self.y = x, y
            self.retracted += d

    def e_move(self, de: float, f: float) -> None:
        """Retract (``de`` < 0) or unretract (``de`` > 0) without moving."""
        ew = self._e_word(de, exact=True)
        if ew is None:
            return
        self._move("G1", [ew], f, abs(de))
        self.retracted -= de

    def z_move(self, z: float, f: float) -> None:
        """Lift or lower to ``z``."""
        self._move("G1", [f"Z{fmt_few(z, 3, self.style.leading_zero)}"], f, abs(z - self.z))
        self.z = z

    def set_e(self, e: float) -> None:
        """``G92 E<e>``: make the logical E what the following lines expect (absolute E)."""
        self._lines.append(f"G92 E{fmt(e, 5, True)}")
        self.e = self._e_exact = e
        self._carry = 0.0

    @property
    def lines(self) -> list[str]:
        """The lines written so far.

        The moves of :meth:`extrude_many` are made here, all those of the writer in one numpy pass
        (their E words, :meth:`_Chains.e_words`; their text, :func:`_move_lines`): per call, the
        fixed cost of the passes outweighed a chain's few dozen lines.
        """
        if self._pending.sizes:
            pend, self._pending = self._pending, _Chains(self.e_relative, self.e_dec)
            to, e_vals, has_e, f, change = pend.moves()
            if self.style.path_xy_decimals < 3:
                # every vertex but a chain's last to the style's decimals: the travel after a chain
                # starts where the travel planner put it (its retraction, its reach out of the region)
                ends = np.cumsum(pend.sizes) - 1
                inner = np.ones(len(to), dtype=bool)
                inner[ends] = False
                to = to.copy()
                to[inner] = np.round(to[inner], self.style.path_xy_decimals)
            head = _move_lines(self.style, to, e_vals, has_e, f, change)
            feed_at = change.tolist() if self.style.feed_line else []
            base = np.cumsum([0, *pend.sizes]).tolist()
            out: list[str] = []
            fi = 0
            for item in self._lines:
                if type(item) is not _Chain:
                    out.append(item)
                    continue
                a, n = base[item.call], pend.sizes[item.call]
                # events before a segment: a width marker and/or a feedrate line, then M73 lines
                events = {k: [f"{self.style.width}{fmt_few(w, 6, True)}"] for k, w in item.marks}
                while fi < len(feed_at) and feed_at[fi] < a + n:
                    k = feed_at[fi]
                    events.setdefault(k - a, []).append("G1 F" + fmt_few(float(f[k]), 3, True))
                    fi += 1
                inserts = item.inserts or {}
                for k, extra in inserts.items():
                    if k + 1 < n:
                        events.setdefault(k + 1, []).extend(extra)
                prev = 0
                for k in sorted(events):
                    if k > prev:
                        out.extend(head[a + prev : a + k])
                    out.extend(events[k])
                    prev = k
                out.extend(head[a + prev : a + n])
                if n - 1 in inserts:
                    out.extend(inserts[n - 1])
            self._lines = out
        return self._lines

    def text(self, newline: str = "\n") -> str:
        """Return the lines written so far, each with ``newline``."""
        lines = self.lines
        return newline.join(lines) + newline if lines else ""


class _Chain:
    """Place of the ``call``-th :meth:`Writer.extrude_many` among the lines: its width markers
    ``(segment, width)`` and its inserted lines (``{segment: lines}``, written after it)."""

    __slots__ = ("call", "marks", "inserts")

    def __init__(self, call: int, marks: list[tuple[int, float]], inserts: dict | None) -> None:
        self.call, self.marks, self.inserts = call, marks, inserts


class _Chains:
    """The moves of a writer's :meth:`Writer.extrude_many` calls not yet written.

    Per call: the end points ``(n, 2)``, the filament ``de`` (file units) and its running sum ``cs``
    (``np.cumsum(de)``), the E state the call started from (``e0``: the rounding carry, relative
    E, or the exact running total, absolute E; ``e_prev``: the E last written, rounded, absolute
    E), the feedrates ``f`` and the feedrate in effect before (``f0``, -1 when unknown).
    """

    def __init__(self, e_relative: bool, e_decimals: int = 5) -> None:
        self.e_relative = e_relative
        self.e_decimals = e_decimals
        self.sizes: list[int] = []
        self.to: list[np.ndarray] = []
        self.cs: list[np.ndarray] = []
        self.f: list[np.ndarray] = []
        self.e0: list[float] = []
        self.e_prev: list[float] = []
        self.f0: list[float] = []

    def add(self, to, de, cs, e0: float, e_prev: float, f, f0: float) -> None:
        """Keep one call's moves (``de`` is not kept: ``cs`` holds what the E words need)."""
        self.sizes.append(len(de))
        self.to.append(to)
        self.cs.append(cs)
        self.f.append(f)
        self.e0.append(e0)
        self.e_prev.append(e_prev)
        self.f0.append(f0)

    def moves(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """All the calls' moves as :func:`_move_lines` takes them: ``to, e_vals, has_e, f, change``.

        Each call's E words as one call alone made them: ``c = e0 + cs`` rounded to 5 decimals, the
        words the differences of the rounded values (relative E; the first one the rounded value
        itself), or the rounded values (absolute E; written where they differ from the one before,
        the first from ``e_prev``); a feedrate change where ``f`` differs from the one before (the
        first from ``f0``).  Element by element the same operations, so the same figures.
        """
        sizes = np.array(self.sizes)
        first = np.zeros(int(sizes.sum()), dtype=bool)
        first[np.cumsum(sizes) - sizes] = True
        c = np.repeat(np.array(self.e0), sizes) + np.concatenate(self.cs)
        r = np.round(c, self.e_decimals)
        if self.e_decimals != 5:
            # each chain's last word rounds its running total to the slicer's 5 decimals: what is
            # left to carry after the chain is as small as with 5 decimals throughout (a block's
            # last carry is not written, and Cura's end code switches to absolute E: the logical E
            # there must be the slicer's to 2e-5 mm)
            last = np.cumsum(sizes) - 1
            r[last] = np.round(c[last], 5)
        before = np.concatenate([[0.0], r[:-1]])
        if self.e_relative:
            written = np.where(first, r, r - before)
            e_vals = written
        else:
            written = np.where(first, r - np.repeat(np.array(self.e_prev), sizes), r - before)
            e_vals = r
        f = np.concatenate(self.f)
        steps = np.where(first, f - np.repeat(np.array(self.f0), sizes), f - np.concatenate([[0.0], f[:-1]]))
        return np.concatenate(self.to), e_vals, np.abs(written) > 0, f, np.flatnonzero(steps != 0)


def _merge_unmoved(pts, de, f, widths, inserts, seg, decimals: int):
    """A chain without the vertices that do not move the nozzle once X and Y are written to ``decimals``.

    Written, such a segment would be ``G1 X.. Y.. E..`` to where the nozzle already is: an E-only
    move, which firmware and the splice check take for a prime.  An inner vertex is dropped where
    it rounds to the vertex before it; the chain's last vertex is kept (it is written exactly,
    :meth:`Writer.lines`), and the inner vertices before it that round to it are dropped instead.
    A new segment extrudes the filament of the segments it spans, at the slowest of their
    feedrates and the width of the last; lines inserted after a segment go after the new segment
    that spans it.

    Parameters
    ----------
    pts : (n + 1, 2) float, mm
    de, f : (n,) float
    widths, seg : (n,) float or None
    inserts : dict of int -> list of str, or None
    decimals : int

    Returns
    -------
    The same six, for the vertices kept.
    """
    q = np.round(pts * 10.0**decimals)
    same = np.all(q[1:] == q[:-1], axis=1)  # (n,) vertex i + 1 rounds to vertex i
    if not same.any():
        return pts, de, f, widths, inserts, seg
    n = len(de)
    keepv = np.ones(n + 1, dtype=bool)
    keepv[1:n] = ~same[: n - 1]
    j = n - 1
    while j > 0 and bool(np.all(q[j] == q[n])):
        keepv[j] = False
        j -= 1
    kv = np.flatnonzero(keepv)
    if len(kv) < 2:
        return pts, de, f, widths, inserts, seg
    # new segment of every old one: the one that ends at the first kept vertex after its start
    new_of = np.searchsorted(kv, np.arange(n), side="right") - 1
    new_de = np.bincount(new_of, weights=de, minlength=len(kv) - 1)
    starts = kv[:-1]
    new_f = np.minimum.reduceat(f, starts)
    new_w = None if widths is None else np.asarray(widths, dtype=float)[kv[1:] - 1]
    new_pts = pts[kv]
    new_ins = None
    if inserts:
        new_ins = {}
        for k, extra in sorted(inserts.items()):
            new_ins.setdefault(int(new_of[min(k, n - 1)]), []).extend(extra)
    new_seg = None if seg is None else np.hypot(*(new_pts[1:] - new_pts[:-1]).T)
    return new_pts, new_de, new_f, new_w, new_ins, new_seg


def width_changes(
    widths, sizes: list[int], step: float, hysteresis: float
) -> list[tuple[list[int], list[float]]]:
    """Where each chain's rounded width may change, for many chains in one numpy pass.

    Parameters
    ----------
    widths : (N,) float, mm
        The segments' widths, chain after chain.
    sizes : list of int
        Segments per chain (each >= 1; they sum to N).
    step, hysteresis : float, mm
        As :meth:`Writer.extrude_many` takes them.

    Returns
    -------
    list of (list of int, list of float)
        Per chain: the segments a marker may go before (its first; with a hysteresis, those whose
        rounded width differs from the segment before's: a segment as wide as the one before adds no
        marker, since that one left the stated width within the hysteresis of it, or stated it; else
        every one) and their rounded widths.  The rounding is element-wise, so the same figures as
        chain by chain (issue 17: per chain, the numpy calls outweighed a chain's few segments).
    """
    wq = np.round(np.asarray(widths, dtype=float) / step) * step
    first = np.cumsum([0, *sizes[:-1]], dtype=np.int64)
    at = np.ones(len(wq), dtype=bool)
    if hysteresis > 0:
        at[1:] = wq[1:] != wq[:-1]
        at[first] = True
    where = np.flatnonzero(at)
    bounds = np.searchsorted(where, np.append(first, len(wq))).tolist()
    local = (where - np.repeat(first, np.diff(bounds))).tolist()
    vals = wq[where].tolist()
    return [(local[a:z], vals[a:z]) for a, z in zip(bounds[:-1], bounds[1:], strict=True)]


def _width_marks(
    at: list[int], ws: list[float], current: float, hysteresis: float
) -> list[tuple[int, float]]:
    """Segments where a width marker goes and the width it states: ``(k, width)`` in order.

    A marker is written where the quantized width ``ws[i]`` (mm, at segment ``at[i]``, from
    :func:`width_changes`) moved ``hysteresis`` mm or more from the last one stated (``current``
    before the first segment, NaN: none).  Sequential by nature; plain floats.
    """
    out = []
    for k, w in zip(at, ws, strict=True):
        if not abs(w - current) < hysteresis:
            current = w
            out.append((k, current))
    return out


def _move_lines(
    style: Style,
    to: np.ndarray,
    e_vals: np.ndarray,
    has_e: np.ndarray,
    f: np.ndarray,
    change: np.ndarray,
) -> list[str]:
    """The text of extrusion moves ``G1 X.. Y.. E..`` (E where ``has_e``), F words where ``change``.

    The F word of a changed feedrate goes first (``f_first``, Cura) or last in the move, unless the
    family writes it on its own line (``feed_line``: the caller's).  Numbers as :func:`fmt` writes
    them (:mod:`loadpath.splice.numtext`; non-finite or huge values through :func:`fmt_many`).

    Parameters
    ----------
    style : Style
    to : (n, 2) float, mm
        End point of each move.
    e_vals : (n,) float
        E word of each move (relative or absolute, as written).
    has_e : (n,) bool
    f : (n,) float, mm/min
    change : (m,) int
        Moves whose feedrate differs from the one before.
    X and Y are written to 3 decimals, E to 5; values rounded coarser before (``Style.path_xy_decimals``
    and ``Style.e_decimals``, :meth:`Writer.lines`) lose their trailing zeros.
    """
    n = len(to)
    lz = style.leading_zero
    dxy, de = 3, 5
    in_line = len(change) and not style.feed_line  # F words inside the moves
    if not (nt.writable(to, dxy) and nt.writable(e_vals, de) and nt.writable(f[change], 3)):
        return _move_lines_plain(style, to, e_vals, has_e, f, change)
    f_word = None
    if in_line:
        at = np.zeros(n, dtype=bool)
        at[change] = True
        f_word = [nt.text_column(" F", n, at), nt.number_column(np.where(at, f, 0.0), 3, True)]
        f_word[1].keep &= at[:, None]
    e_col = nt.number_column(e_vals, de, lz)
    e_col.keep &= has_e[:, None]
    cols = [nt.text_column("G1", n)]
    if f_word is not None and style.f_first:
        cols += f_word
    cols += [
        nt.text_column(" X", n),
        nt.number_column(to[:, 0], dxy, lz),
        nt.text_column(" Y", n),
        nt.number_column(to[:, 1], dxy, lz),
        nt.text_column(" E", n, has_e),
        e_col,
    ]
    if f_word is not None and not style.f_first:
        cols += f_word
    return nt.lines(cols)


def _move_lines_plain(
    style: Style,
    to: np.ndarray,
    e_vals: np.ndarray,
    has_e: np.ndarray,
    f: np.ndarray,
    change: np.ndarray,
) -> list[str]:
    """:func:`_move_lines` one value at a time (:func:`fmt_many`): for values numpy cannot write
    (NaN, infinity), and the reference the tests hold the numpy pass to."""
    lz = style.leading_zero
    dxy, de = 3, 5
    xs, ys, es = fmt_many(to[:, 0], dxy, lz), fmt_many(to[:, 1], dxy, lz), fmt_many(e_vals, de, lz)
    head = [
        f"G1 X{x} Y{y} E{e}" if h else f"G1 X{x} Y{y}"
        for x, y, e, h in zip(xs, ys, es, has_e.tolist(), strict=True)
    ]
    for k in change.tolist() if not style.feed_line else ():
        fw = "F" + fmt(float(f[k]), 3, True)
        head[k] = head[k].replace("G1 ", f"G1 {fw} ", 1) if style.f_first else f"{head[k]} {fw}"
    return head
