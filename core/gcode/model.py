"""The G-code program: original bytes, per-line machine state, per-layer moves and feature blocks.

See :mod:`loadpath.gcode` for the overview; this module holds the data classes and dtypes.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from loadpath._typing import Ints
from loadpath.gcode.flavors import Dialect, Role
from loadpath.gcode.state import LineState

__all__ = ["MOVE_DTYPE", "Program", "Layer", "Block", "MachineState", "climbing"]

MOVE_DTYPE = np.dtype(
    [
        ("x0", "f8"),
        ("y0", "f8"),
        ("z0", "f8"),  # start point, mm
        ("x1", "f8"),
        ("y1", "f8"),
        ("z1", "f8"),  # end point, mm
        ("e", "f8"),  # filament pushed (> 0) or pulled (< 0), mm, whatever the E mode (volumetric converted)
        ("f", "f8"),  # feedrate, mm/min (NaN before the first F)
        ("width", "f8"),  # ;WIDTH: / ; LINE_WIDTH: in effect, mm (NaN when the file has none: Cura)
        ("height", "f8"),  # ;HEIGHT: in effect, else the layer height, mm
        ("line", "i8"),  # 0-based index of the G-code line (an arc gives several moves with one line)
        ("layer", "i4"),  # index into Program.layers, -1 outside any layer (start / end G-code)
        ("feature", "i2"),  # index into Program.features (the slicer's name), -1 before any marker
        ("role", "i1"),  # loadpath.gcode.Role of the feature
        ("object", "i2"),  # index into Program.objects, -1 outside any object label
        ("tool", "i2"),  # active tool T<n>
        ("travel", "?"),  # XY move without E (not a wipe)
        ("extrude", "?"),  # XY move with E > 0
        ("retract", "?"),  # E < 0 without XY move, or G10
        ("unretract", "?"),  # E > 0 without XY move, or G11
        ("wipe", "?"),  # XY move with E < 0, or an E-less XY move inside ;WIPE_START..;WIPE_END
        ("lift", "?"),  # Z goes up on a move that does not extrude
        ("lower", "?"),  # Z goes down on a move that does not extrude
        ("arc", "?"),  # a chord of a G2/G3 arc
    ]
)
"""Fields of one move (one row of ``Program.moves``)."""


def climbing(moves: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: the moves (MOVE_DTYPE rows) that change Z as they go, by more than a micrometre
    (a spiral vase's walls climb while they print; a lift or a layer change is a move of its own)."""
    return np.abs(moves["z1"] - moves["z0"]) > 1e-6


@dataclass(frozen=True)
class MachineState:
    """The machine state at one point of the file (what the next line starts from).

    Attributes
    ----------
    line : int
        The state is the one after this line (-1: the initial state before the file).
    x, y, z : float, mm
        Logical position.
    e : float, file units
        E axis position as the firmware counts it (absolute E: the value the next absolute E word
        continues from; relative E: the sum since the last ``G92 E``).
    f : float, mm/min
        Modal feedrate (NaN before the first ``F``).
    absolute_xyz, e_relative : bool
        ``G90`` in effect; E words relative (``M83`` or ``G91``).
    retracted : float, mm
        Filament currently retracted by E moves (0 when primed).
    fw_retracted : bool
        Inside ``G10`` ... ``G11``.
    feature : str or None
        Feature name in effect (``"Internal infill"``, ``"FILL"``).
    width, height : float, mm
        ``;WIDTH:`` and height in effect (NaN when unknown).
    layer : int
        Layer index (-1 outside layers).
    object : str or None
        Object label in effect.
    wipe : bool
        Inside ``;WIPE_START`` ... ``;WIPE_END``.
    tool : int
    """

    line: int
    x: float
    y: float
    z: float
    e: float
    f: float
    absolute_xyz: bool
    e_relative: bool
    retracted: float
    fw_retracted: bool
    feature: str | None
    width: float
    height: float
    layer: int
    object: str | None
    wipe: bool
    tool: int


@dataclass(frozen=True)
class Block:
    """One feature block (see :mod:`loadpath.gcode.blocks` for the exact line ranges).

    Attributes
    ----------
    index : int
        Row in ``Program.blocks``.
    layer : int
        Layer index.
    feature : str
        The slicer's feature name (``"Internal infill"``, ``"Sparse infill"``, ``"FILL"``).
    role : Role
    object : str or None
        Object label (``"ohs.stl id:0 copy 0"``, Cura's ``;MESH:`` path), None without labels.
    start, stop : int
        Core lines ``[start, stop)``: opening markers to the last extrusion.
    span_start, span_stop : int
        Contiguous lines with the entering travel and the directly following wipe/retraction.
    exit_start, exit_stop : int
        The leaving wipe/retraction wherever it is (may be after barrier lines); empty if none.
    type_line : int
        Line of the feature marker (-1 when the feature was set before the layer began).
    moves : slice
        Rows of ``Program.moves`` inside the core.
    e, length : float, mm
        Filament extruded and path length extruded in the block.
    """

    index: int
    layer: int
    feature: str
    role: Role
    object: str | None
    start: int
    stop: int
    span_start: int
    span_stop: int
    exit_start: int
    exit_stop: int
    type_line: int
    moves: slice
    e: float
    length: float

    @property
    def detached_exit(self) -> bool:
        """Whether the leaving wipe/retraction lies after the span (past barrier lines), not in it."""
        return self.exit_start >= self.span_stop and self.exit_stop > self.exit_start

    @property
    def spans(self) -> list[tuple[int, int]]:
        """The line ranges ``[start, stop)`` a replacement rewrites: the span, then the detached exit."""
        out = [(self.span_start, self.span_stop)]
        if self.detached_exit:
            out.append((self.exit_start, self.exit_stop))
        return out


@dataclass(frozen=True, eq=False)
class Layer:
    """One layer: its lines, its moves and its blocks.

    Attributes
    ----------
    index : int
        0-based position in the file.
    number : int
        The slicer's own number (Cura's ``;LAYER:n``, negative with a raft; else ``index``).
    z : float, mm
        Print Z (top of the layer): ``;Z:`` / ``; Z_HEIGHT:``, else the Z of its first extrusion.
    height : float, mm
        ``;HEIGHT:`` / ``; LAYER_HEIGHT:``, else Z minus the previous layer's Z (Z for the first).
    start, stop : int
        Lines ``[start, stop)``: from the layer marker to the next layer's marker (the last layer ends
        where the end G-code / trailer begins).
    moves : structured ndarray (MOVE_DTYPE)
        View of the layer's rows of ``Program.moves``.
    blocks : structured ndarray (BLOCK_DTYPE)
        View of the layer's rows of ``Program.blocks``.
    """

    index: int
    number: int
    z: float
    height: float
    start: int
    stop: int
    moves: np.ndarray = field(repr=False)
    blocks: np.ndarray = field(repr=False)

    @property
    def roles(self) -> set[Role]:
        """Roles that extrude in this layer (empty set: nothing printed)."""
        return {Role(r) for r in np.unique(self.moves["role"][self.moves["extrude"]])}

    @property
    def extrusions(self) -> np.ndarray:
        """The layer's extruding moves (``moves[moves['extrude']]``)."""
        return self.moves[self.moves["extrude"]]


@dataclass(frozen=True, eq=False)
class Program:
    r"""A parsed G-code file.  Build it with :func:`loadpath.gcode.parse` or :func:`~loadpath.gcode.read`.

    Attributes
    ----------
    data : bytes
        The file, unchanged; :meth:`to_bytes` returns it.
    line_starts : (n_lines + 1,) int64
        Byte offset of each line's first byte; ``line_starts[-1] == len(data)``.
    line_ends : (n_lines,) int64
        Byte offset where each line's content ends (before its ``\r\n`` / ``\n``).
    dialect : Dialect
    state : LineState
        Machine state after every line (arrays indexed by line).
    feature_of_line, object_of_line, layer_of_line : (n_lines,) int
        Feature code, object code and layer index in effect after each line (-1: none).
    width_of_line, height_of_line : (n_lines,) float64, mm
    wipe_of_line : (n_lines,) bool
    kind_of_line : (n_lines,) int8
        Line kind (:data:`loadpath.gcode.blocks.KINDS`).
    moves : structured ndarray (MOVE_DTYPE)
        Every move of the file in order; arcs sampled into chords.
    blocks : structured ndarray (BLOCK_DTYPE)
        Every feature block in order.
    layers : tuple of Layer
    features : tuple of str
        Feature names as written; ``moves['feature']`` indexes this.
    objects : tuple of str
        Object labels as written; ``moves['object']`` indexes this.
    config : dict of str -> str
        The slicer configuration embedded in the file (PrusaSlicer config block, Orca/Bambu
        ``CONFIG_BLOCK``, Cura ``;SETTING_3``); values verbatim.
    header : dict of str -> str
        Header facts (``"generated by"``, Cura's ``FLAVOR``, ``Layer height``, ...).
    header_widths : dict of str -> float, mm
        PrusaSlicer's ``; <what> extrusion width = <w>mm`` lines (``"external perimeters"``,
        ``"perimeters"``, ``"infill"``, ``"solid infill"``, ``"top infill"``, ``"first layer"``...).
    print_end : int
        First line after the last layer (end G-code, statistics, config block).
    """

    data: bytes = field(repr=False)
    line_starts: Ints = field(repr=False)
    line_ends: Ints = field(repr=False)
    dialect: Dialect
    state: LineState = field(repr=False)
    feature_of_line: np.ndarray = field(repr=False)
    object_of_line: np.ndarray = field(repr=False)
    layer_of_line: np.ndarray = field(repr=False)
    width_of_line: np.ndarray = field(repr=False)
    height_of_line: np.ndarray = field(repr=False)
    wipe_of_line: np.ndarray = field(repr=False)
    kind_of_line: np.ndarray = field(repr=False)
    moves: np.ndarray = field(repr=False)
    blocks: np.ndarray = field(repr=False)
    layers: tuple[Layer, ...] = field(repr=False)
    features: tuple[str, ...]
    objects: tuple[str, ...]
    config: dict[str, str] = field(repr=False)
    header: dict[str, str] = field(repr=False)
    header_widths: dict[str, float] = field(repr=False)
    print_end: int = 0

    # ------------------------------------------------------------------ text

    def to_bytes(self) -> bytes:
        """Return the file's bytes: identical to the input for a program read from a file."""
        return self.data

    @property
    def n_lines(self) -> int:
        """Number of lines (a final line without a line ending counts)."""
        return len(self.line_ends)

    @cached_property
    def text(self) -> str:
        """The file decoded as UTF-8."""
        return self.data.decode("utf-8")

    def line(self, i: int) -> str:
        """Line ``i`` (0-based) without its line ending."""
        return self.data[self.line_starts[i] : self.line_ends[i]].decode("utf-8")

    def lines_bytes(self, start: int, stop: int) -> bytes:
        """Lines ``[start, stop)`` with their line endings, as in the file."""
        return self.data[self.line_starts[start] : self.line_starts[stop]]

    @cached_property
    def newline(self) -> bytes:
        r"""The file's dominant line ending (``b"\n"`` or ``b"\r\n"``)."""
        crlf = self.data.count(b"\r\n")
        return b"\r\n" if crlf * 2 > self.n_lines else b"\n"

    def replace_lines(self, edits: Iterable[tuple[int, int, bytes]]) -> bytes:
        """Return the file with line ranges replaced; every other byte unchanged.

        Parameters
        ----------
        edits : iterable of (start, stop, new_bytes)
            Half-open line ranges, non-overlapping; ``new_bytes`` should end with a line ending.
        """
        out, pos = [], 0
        for start, stop, new in sorted(edits, key=lambda t: (t[0], t[1])):
            a, b = int(self.line_starts[start]), int(self.line_starts[stop])
            if a < pos:
                raise ValueError(f"edits overlap at line {start + 1}")
            out += [self.data[pos:a], new]
            pos = b
        out.append(self.data[pos:])
        return b"".join(out)

    # ------------------------------------------------------------------ state

    def state_after(self, i: int) -> MachineState:
        """Machine state after line ``i`` (``i = -1``: the initial state)."""
        s = self.state
        if i < 0:
            return MachineState(
                line=-1,
                x=0.0,
                y=0.0,
                z=0.0,
                e=0.0,
                f=float("nan"),
                absolute_xyz=True,
                e_relative=False,
                retracted=0.0,
                fw_retracted=False,
                feature=None,
                width=float("nan"),
                height=float("nan"),
                layer=-1,
                object=None,
                wipe=False,
                tool=0,
            )
        fcode, ocode = int(self.feature_of_line[i]), int(self.object_of_line[i])
        return MachineState(
            line=i,
            x=float(s.x[i]),
            y=float(s.y[i]),
            z=float(s.z[i]),
            e=float(s.e[i]),
            f=float(s.f[i]),
            absolute_xyz=bool(s.absolute_xyz[i]),
            e_relative=bool(s.e_relative[i]),
            retracted=float(s.retracted[i]),
            fw_retracted=bool(s.fw_retracted[i]),
            feature=self.features[fcode] if fcode >= 0 else None,
            width=float(self.width_of_line[i]),
            height=float(self.height_of_line[i]),
            layer=int(self.layer_of_line[i]),
            object=self.objects[ocode] if ocode >= 0 else None,
            wipe=bool(self.wipe_of_line[i]),
            tool=int(s.tool[i]),
        )

    def state_before(self, i: int) -> MachineState:
        """Machine state line ``i`` starts from (the state after line ``i - 1``)."""
        return self.state_after(i - 1)

    # ------------------------------------------------------------------ moves and blocks

    @cached_property
    def _move_lines(self) -> Ints:
        """``moves["line"]`` as one contiguous array: searching the structured array's strided field
        copies it on every call (0.35 ms a call on a 100-layer file)."""
        return np.ascontiguousarray(self.moves["line"])

    def move_rows(self, start: int, stop: int) -> slice:
        """Rows of :attr:`moves` produced by lines ``[start, stop)``."""
        a, z = np.searchsorted(self._move_lines, (start, stop), "left")
        return slice(int(a), int(z))

    def block(self, i: int) -> Block:
        """Row ``i`` of :attr:`blocks` with names resolved."""
        b = self.blocks[i]
        obj = int(b["object"])
        return Block(
            index=i,
            layer=int(b["layer"]),
            feature=self.features[int(b["feature"])],
            role=Role(int(b["role"])),
            object=self.objects[obj] if obj >= 0 else None,
            start=int(b["start"]),
            stop=int(b["stop"]),
            span_start=int(b["span_start"]),
            span_stop=int(b["span_stop"]),
            exit_start=int(b["exit_start"]),
            exit_stop=int(b["exit_stop"]),
            type_line=int(b["type_line"]),
            moves=slice(int(b["move_start"]), int(b["move_stop"])),
            e=float(b["e"]),
            length=float(b["length"]),
        )

    def blocks_of(self, layer: int | Layer) -> list[Block]:
        """Return the blocks of one layer, in file order, as :class:`Block` objects."""
        index = layer.index if isinstance(layer, Layer) else int(layer)
        rows = np.flatnonzero(self.blocks["layer"] == index)
        return [self.block(int(i)) for i in rows]

    def summary(self) -> dict[str, Any]:
        """Count layers, moves, blocks and objects (for messages and reports)."""
        return {
            "dialect": self.dialect.name,
            "family": self.dialect.family,
            "lines": self.n_lines,
            "layers": len(self.layers),
            "moves": len(self.moves),
            "blocks": len(self.blocks),
            "objects": list(self.objects),
        }
