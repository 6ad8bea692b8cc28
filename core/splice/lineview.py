"""A spliced file read for its check only: the per-line arrays the check compares, no Program.

:func:`loadpath.splice.verify.check_output` checks a splice from the output's bytes.  Building the
output's whole :class:`~loadpath.gcode.model.Program` for that (a move table, blocks, layers, every
per-line array) took 1.8 GB at its peak for a 4.6M-line output, beside the input's own Program.
:func:`read_lines` runs the same parse stages (:mod:`.lines`, :mod:`.words`, :mod:`.markers`,
:mod:`.state`, :mod:`.blocks`) with the same arguments, so every array it returns is the one the
Program would hold, bit for bit; it keeps only what the check uses and frees the word values as
soon as the machine state is known.  Moves are formed per line range when the check asks
(:meth:`LineView.extrusions`), exactly as :mod:`.parse` forms them for lines without arcs; a range
with an arc is the caller's to hand to the full parse.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath.gcode.blocks import line_kinds
from loadpath.gcode.flavors import Dialect, detect_slicer
from loadpath.gcode.lines import check_text, index_lines
from loadpath.gcode.markers import Markers, read_markers
from loadpath.gcode.parse import _HEAD, _print_end, _refuse_inches, _volumetric_area
from loadpath.gcode.state import LineState, Start, ffill, is_motion, machine_state
from loadpath.gcode.words import BIT, G, Tokens, tokenize

__all__ = ["LineView", "read_lines", "read_piece", "Piece", "Carry", "EXTRUSION_DTYPE", "FAMILIES"]

FAMILIES = ("prusa", "bambu", "cura")
"""Layer-marker families, in the order :func:`read_lines` prefers them on a tie."""

EXTRUSION_DTYPE = np.dtype(
    [("x0", "f8"), ("y0", "f8"), ("x1", "f8"), ("y1", "f8"), ("e", "f8"), ("width", "f8")]
)
"""The fields of an extruding move the check reads (as in :data:`loadpath.gcode.model.MOVE_DTYPE`)."""


@dataclass(frozen=True)
class LineView:
    """Per-line arrays of a G-code file, as :func:`loadpath.gcode.parse` would compute them.

    Attributes
    ----------
    data : bytes
    line_starts, line_ends : (n,) int64
        Byte offsets of each line and of its line ending.
    dialect : Dialect
    state : LineState
        Machine state after each line.
    kind_of_line : (n,) int8
    layer_of_line : (n,) int32
        -1 outside layers (start and end G-code).
    feature_of_line : (n,) int16
        Index into ``features``, -1 before any marker.
    width_of_line : (n,) float64, mm
    arc_lines : (n,) bool
        G2/G3 lines.
    features : tuple of str
    n_layers : int
    """

    data: bytes
    line_starts: np.ndarray
    line_ends: np.ndarray
    dialect: Dialect
    state: LineState
    kind_of_line: np.ndarray
    layer_of_line: np.ndarray
    feature_of_line: np.ndarray
    width_of_line: np.ndarray
    arc_lines: np.ndarray
    features: tuple[str, ...]
    n_layers: int

    @property
    def n_lines(self) -> int:
        """Number of lines."""
        return len(self.line_ends)

    def line(self, i: int) -> str:
        """Line ``i`` without its line ending (as :meth:`Program.line`)."""
        return self.data[self.line_starts[i] : self.line_ends[i]].decode("utf-8")

    def lines_bytes(self, start: int, stop: int) -> bytes:
        """Lines ``[start, stop)`` with their line endings (as :meth:`Program.lines_bytes`)."""
        return self.data[self.line_starts[start] : self.line_starts[stop]]

    def has_arcs(self, start: int, stop: int) -> bool:
        """Whether lines ``[start, stop)`` hold a G2/G3 arc."""
        return bool(self.arc_lines[start:stop].any())

    def extrusions(self, start: int, stop: int, origin: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """Return the extruding moves of lines ``[start, stop)`` (without arcs), in file order.

        ``origin`` (mm): where the first line starts from (the initial position; for a piece of a
        file, :func:`read_piece`, where the previous piece ended).

        Returns
        -------
        (m,) EXTRUSION_DTYPE
            The ``x0 y0 x1 y1 e width`` of the rows of ``Program.moves`` with ``extrude`` set.
        """
        st = self.state
        lines = start + np.flatnonzero(st.moved_xy[start:stop] & (st.de[start:stop] > 0))
        out = np.zeros(len(lines), dtype=EXTRUSION_DTYPE)
        before = lines - 1  # a move starts from the state after the previous line (initially 0)
        out["x0"], out["y0"] = st.x[before], st.y[before]
        if len(lines) and lines[0] == 0:
            out["x0"][0], out["y0"][0] = origin
        out["x1"], out["y1"] = st.x[lines], st.y[lines]
        out["e"], out["width"] = st.de[lines], self.width_of_line[lines]
        return out

    def layer_features(self) -> list[set[str]]:
        """Feature names that extrude, per layer (as :func:`loadpath.splice.verify.layer_features`)."""
        st = self.state
        ext = np.flatnonzero(st.moved_xy & (st.de > 0) & (self.layer_of_line >= 0))
        out: list[set[str]] = [set() for _ in range(self.n_layers)]
        pairs = set(zip(self.layer_of_line[ext].tolist(), self.feature_of_line[ext].tolist(), strict=True))
        for layer, feat in pairs:
            out[layer].add(self.features[feat] if feat >= 0 else "")
        return out


def _slim(tok: Tokens) -> tuple[Tokens, np.ndarray, np.ndarray]:
    """The words the machine state reads (arcs are the full parse's: check_output hands them over).

    Returns the slim tokens, which lines carry an X, Y, Z or E word and which carry no other word
    (n,) bool each: the caller then drops ``tok``, whose other word values are the largest part of
    a parse, before the machine state is computed.
    """
    has_axes = (tok.present & np.uint16(BIT["X"] | BIT["Y"] | BIT["Z"] | BIT["E"])) != 0
    slim = Tokens(
        cmd=tok.cmd,
        code_end=np.zeros(0, dtype=np.int64),
        comment=np.zeros(0, dtype=bool),
        values={c: tok.values[c] for c in "XYZEF"},
        present=tok.present,
        other_words=tok.other_words,
    )
    return slim, has_axes, ~tok.other_words


def _kinds(cmd, st: LineState, in_wipe, wipe_lines, barrier_lines, fw_ok, moves) -> np.ndarray:
    """:func:`loadpath.gcode.blocks.line_kinds` of lines read here (``G10``/``G11`` firmware retraction
    only on lines with no other word, ``moves``: lines with an axis word or an arc)."""
    return line_kinds(
        cmd,
        is_motion(cmd),
        st.moved_xy,
        st.de,
        in_wipe,
        wipe_lines,
        barrier_lines,
        (cmd == G + 10) & fw_ok,
        (cmd == G + 11) & fw_ok,
        moves,
    )


def read_lines(data: bytes) -> LineView:
    """Read ``data`` (text G-code) into a :class:`LineView` (the stages of :func:`parse_bytes`).

    Memory: what the machine state does not need (the byte index's padded copy, the arc words,
    the markers' lists) is dropped before it is computed, since that step peaks highest.

    Raises what :func:`loadpath.gcode.parse` raises on text it refuses (not UTF-8, inches).
    """
    check_text(data)
    idx = index_lines(data)
    tok = tokenize(idx)
    _refuse_inches(data, idx.starts, tok)
    mk = read_markers(data, idx, tok)
    starts, ends = idx.starts, idx.ends
    del idx  # its padded copy of the bytes
    slicer, version = detect_slicer(data[:_HEAD])
    counts = {fam: len(lines) for fam, lines in mk.layer_lines.items()}
    family = max(counts, key=lambda k: counts[k]) if any(counts.values()) else "none"
    n = len(ends)
    cmd = tok.cmd
    arc_lines = (cmd == G + 2) | (cmd == G + 3)
    feature = ffill(
        n,
        np.asarray(mk.feature_lines, dtype=np.int64),
        np.asarray(mk.feature_codes, dtype=np.int16),
        np.int16(-1),
    )
    width = ffill(
        n, np.asarray(mk.width_lines, dtype=np.int64), np.asarray(mk.width_values, dtype=float), np.nan
    )
    in_wipe = ffill(
        n, np.asarray(mk.wipe_lines, dtype=np.int64), np.asarray(mk.wipe_values, dtype=bool), False
    )
    layer_starts = np.asarray(mk.layer_lines.get(family, []), dtype=np.int64)
    wipe_lines, barrier_lines = np.asarray(mk.wipe_lines, dtype=np.int64), mk.barrier_lines
    features, area = tuple(mk.features), _volumetric_area(mk.config)
    ends_of_print = Markers(
        end_lines=mk.end_lines, custom_lines=mk.custom_lines, time_elapsed_lines=mk.time_elapsed_lines
    )  # what _print_end reads
    del mk
    slim, has_axes, fw_ok = _slim(tok)
    del tok
    st = machine_state(slim, arc_lines, area)
    del slim  # the word values: the largest part of a parse
    extrusion_lines = np.flatnonzero(st.moved_xy & (st.de > 0))
    print_end = _print_end(ends_of_print, family, layer_starts, extrusion_lines, n)
    del extrusion_lines
    layer_of_line = ffill(n, layer_starts, np.arange(len(layer_starts), dtype=np.int32), np.int32(-1))
    layer_of_line[print_end:] = -1
    kinds = _kinds(cmd, st, in_wipe, wipe_lines, barrier_lines, fw_ok, has_axes | arc_lines)
    return LineView(
        data=data,
        line_starts=starts,
        line_ends=ends,
        dialect=Dialect(slicer=slicer, version=version, family=family),
        state=st,
        kind_of_line=kinds,
        layer_of_line=layer_of_line,
        feature_of_line=feature,
        width_of_line=width,
        arc_lines=arc_lines,
        features=features,
        n_layers=len(layer_starts),
    )


@dataclass(frozen=True)
class Carry:
    """What a piece of a file inherits from the lines before it (:func:`read_piece`).

    Attributes
    ----------
    start : Start
        The machine state after the previous piece.
    feature : int
        Index into the caller's list of feature names in effect (-1: none yet).
    width : float, mm
        ``;WIDTH:`` in effect (NaN: none yet).
    wipe : bool
        Inside ``;WIPE_START`` ... ``;WIPE_END``.
    """

    start: Start = Start()
    feature: int = -1
    width: float = float("nan")
    wipe: bool = False


@dataclass(frozen=True)
class Piece:
    """A run of lines read on its own: its :class:`LineView` (local line numbers) and its markers.

    Attributes
    ----------
    view : LineView
        ``layer_of_line`` is all -1 and ``n_layers`` 0 (the layers are the whole file's to count:
        ``layer_lines``); ``features`` is the caller's list of names as it stood after this piece.
    layer_lines : dict of str -> (k,) int64
        Local lines of each family's layer markers (:data:`FAMILIES`).
    end_lines, custom_lines, time_elapsed_lines : (k,) int64
        Local lines of the markers :func:`loadpath.gcode.parse._print_end` reads.
    carry : Carry
        What the next piece starts from.
    """

    view: LineView
    layer_lines: dict[str, np.ndarray]
    end_lines: np.ndarray
    custom_lines: np.ndarray
    time_elapsed_lines: np.ndarray
    carry: Carry


def read_piece(data: bytes, carry: Carry, names: list[str], area: float | None) -> Piece:
    """Read whole lines ``data`` (a piece of a file) as :func:`read_lines` reads a file, from ``carry``.

    A piece cut where no multi-line marker block is open (a config block, thumbnails: the header
    and the trailer) gets the arrays the whole file's read has on those lines, but for the rounding
    of sums of relative moves (:func:`loadpath.gcode.state.machine_state`).

    Parameters
    ----------
    data : bytes
        Whole lines (the last may lack its line ending only at the end of the file).
    carry : Carry
        The state the previous piece ended in (``Carry()`` for the file's first piece).
    names : list of str
        Feature names met so far; new ones are appended (the codes of ``feature_of_line`` index it).
    area : float or None, mm^2
        Filament cross-section when E is volumetric (the file's config: its header or trailer).
    """
    idx = index_lines(data)
    tok = tokenize(idx)
    _refuse_inches(data, idx.starts, tok)
    mk = read_markers(data, idx, tok)
    starts, ends = idx.starts, idx.ends
    del idx
    n = len(ends)
    code = {name: k for k, name in enumerate(names)}
    for name in mk.features:
        if name not in code:
            code[name] = len(names)
            names.append(name)
    glob = np.array([code[name] for name in mk.features] + [-1], dtype=np.int16)
    cmd = tok.cmd
    arc_lines = (cmd == G + 2) | (cmd == G + 3)
    feature = ffill(
        n,
        np.asarray(mk.feature_lines, dtype=np.int64),
        glob[np.asarray(mk.feature_codes, dtype=np.int64)],
        np.int16(carry.feature),
    )
    width = ffill(
        n, np.asarray(mk.width_lines, dtype=np.int64), np.asarray(mk.width_values, dtype=float), carry.width
    )
    in_wipe = ffill(
        n, np.asarray(mk.wipe_lines, dtype=np.int64), np.asarray(mk.wipe_values, dtype=bool), carry.wipe
    )
    slim, has_axes, fw_ok = _slim(tok)
    del tok
    st = machine_state(slim, arc_lines, area, carry.start)
    del slim
    kinds = _kinds(
        cmd, st, in_wipe, np.asarray(mk.wipe_lines, dtype=np.int64), mk.barrier_lines, fw_ok, has_axes | arc_lines
    )
    view = LineView(
        data=data,
        line_starts=starts,
        line_ends=ends,
        dialect=Dialect(slicer="unknown", version="", family="none"),
        state=st,
        kind_of_line=kinds,
        layer_of_line=np.full(n, -1, dtype=np.int32),
        feature_of_line=feature,
        width_of_line=width,
        arc_lines=arc_lines,
        features=tuple(names),
        n_layers=0,
    )
    nxt = Carry(
        start=carry.start.after(st),
        feature=int(feature[-1]) if n else carry.feature,
        width=float(width[-1]) if n else carry.width,
        wipe=bool(in_wipe[-1]) if n else carry.wipe,
    )
    lines = {fam: np.asarray(mk.layer_lines.get(fam, []), dtype=np.int64) for fam in FAMILIES}
    return Piece(
        view,
        lines,
        np.asarray(mk.end_lines, dtype=np.int64),
        np.asarray(mk.custom_lines, dtype=np.int64),
        np.asarray(mk.time_elapsed_lines, dtype=np.int64),
        nxt,
    )
