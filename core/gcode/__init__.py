r"""Lossless G-code model: every original line kept, machine state per line, moves and blocks per layer.

Reading
-------
>>> from loadpath import gcode
>>> program = gcode.read("examples/ohs.gcode")           # doctest: +SKIP
>>> program.to_bytes() == open("examples/ohs.gcode", "rb").read()   # byte for byte  # doctest: +SKIP
True

:func:`parse` (bytes or str) and :func:`read` (path) return a :class:`Program`.  Unmodified,
``program.to_bytes()`` is the input byte for byte (line endings, trailing blanks, encoding).

Dialects are detected from the file itself (:class:`Dialect`): the header line names the slicer
(PrusaSlicer, SuperSlicer, OrcaSlicer, BambuStudio, Cura) and the layer markers found decide the
marker family (``"prusa"``: ``;LAYER_CHANGE``/``;TYPE:``/``;WIDTH:``/``;HEIGHT:``; ``"bambu"``:
``; CHANGE_LAYER``/``; FEATURE:``/``; LINE_WIDTH:``; ``"cura"``: ``;LAYER:n``/``;TYPE:``/``;MESH:``).

What a Program holds (all arrays numpy, indexed by 0-based line number or move row)
--------------------------------------------------------------------------------------
- ``program.state`` (:class:`LineState`): machine state **after** each line: ``x, y, z`` (mm,
  logical), ``e`` (E axis as the firmware counts it), ``de`` (mm of filament this line pushed/pulled,
  any E mode), ``f`` (mm/min), ``absolute_xyz``, ``e_relative``, ``moved_xy``, ``retracted`` (mm of
  filament held back by retract/wipe moves), ``fw_retracted`` (G10/G11), ``tool``, ``cmd``.
  ``program.state_before(i)`` / ``state_after(i)`` give a :class:`MachineState` with names resolved.
- Per line also: ``feature_of_line``, ``object_of_line``, ``layer_of_line``, ``width_of_line``,
  ``height_of_line``, ``wipe_of_line``, ``kind_of_line`` (:data:`KINDS`).
- ``program.moves``: one structured array (:data:`MOVE_DTYPE`) of every move in file order: start and
  end point (``x0 y0 z0 x1 y1 z1``, mm), ``e`` (mm of filament), ``f``, ``width``, ``height``,
  ``line``, ``layer``, ``feature``, ``role`` (:class:`Role`), ``object``, ``tool`` and the flags
  ``travel extrude retract unretract wipe lift lower arc``.  G2/G3 arcs are sampled into chords
  (within ``TOL.arc_chord_mm``), each chord carrying the arc's line.
- ``program.layers``: :class:`Layer` objects (``index``, ``number``, ``z``, ``height``, ``start``,
  ``stop``, ``moves`` = view of the layer's rows, ``blocks`` = view of its blocks, ``roles``).
- ``program.blocks``: :data:`BLOCK_DTYPE` rows, one per feature block, with the line ranges a splicer
  replaces (``start:stop`` core, ``span_start:span_stop`` with entering travel and leaving
  wipe/retraction, ``exit_start:exit_stop`` the leaving wipe/retraction wherever it is); see
  :mod:`loadpath.gcode.blocks`.  ``program.block(i)`` / ``blocks_of(layer)`` give :class:`Block`.
- ``program.features`` / ``objects``: names indexed by the codes above; ``config`` (the embedded
  slicer configuration), ``header``, ``header_widths``; ``dialect``; ``print_end``.
- Text: ``line(i)``, ``lines_bytes(start, stop)``, ``replace_lines([(start, stop, new_bytes), ...])``.

Bad input raises a one-line :class:`~loadpath.errors.GCodeParseError` or
:class:`~loadpath.errors.UnsupportedFlavorError` naming what, where and the fix: empty file, not
text, binary G-code, inch units (``G20``), no layer markers, truncated file (:mod:`.checks`),
malformed motion words.  ``parse(..., strict=False)`` skips the structural checks (no layer markers,
truncation) for excerpts and generated snippets.

Binary G-code (``GCDE`` magic, PrusaSlicer 2.7+) goes through one hook, :func:`decode_container`,
which decodes it with :mod:`loadpath.gcode.bgcode` to its G-code text.  :func:`read` then fills
``program.config`` from the file's slicer metadata block (a binary file's text has no config
block).  To write a processed file back in the same format, :func:`read_container` also returns
the decoded container and :func:`encode_like` re-encodes new text with the same metadata,
thumbnails and compression.
"""

from __future__ import annotations

import dataclasses
import os

from loadpath.errors import GCodeParseError, UnsupportedFlavorError
from loadpath.gcode.blocks import BLOCK_DTYPE, KINDS
from loadpath.gcode.flavors import Dialect, Role, role_of
from loadpath.gcode.model import MOVE_DTYPE, Block, Layer, MachineState, Program
from loadpath.gcode.parse import parse_bytes
from loadpath.gcode.state import LineState

__all__ = [
    "parse",
    "read",
    "decode_container",
    "read_container",
    "encode_like",
    "Program",
    "Layer",
    "Block",
    "MachineState",
    "LineState",
    "Dialect",
    "Role",
    "role_of",
    "MOVE_DTYPE",
    "BLOCK_DTYPE",
    "KINDS",
    "BINARY_MAGIC",
]

BINARY_MAGIC = b"GCDE"
"""First four bytes of a binary G-code file (``.bgcode``, PrusaSlicer 2.7+)."""


def decode_container(data: bytes, source: str = "the file") -> bytes:
    """Turn a file's bytes into G-code text bytes: the single hook for container formats.

    Plain G-code is returned unchanged; binary G-code (``GCDE`` magic) is decoded to its text
    (:func:`loadpath.gcode.bgcode.decode`).

    Raises
    ------
    UnsupportedFlavorError
        Binary G-code that cannot be decoded (with the reason, and the fix).
    """
    if data[:4] != BINARY_MAGIC:
        return data
    return _decode_binary(data, source).gcode_bytes


def _decode_binary(data: bytes, source: str):
    from loadpath.gcode import bgcode

    try:
        return bgcode.decode(data)
    except (GCodeParseError, UnsupportedFlavorError) as exc:
        raise UnsupportedFlavorError(
            f"{source} is binary G-code (.bgcode, starts with 'GCDE') that cannot be decoded ({exc}); export "
            "it again, or turn binary G-code off in PrusaSlicer (Printer Settings > General > Firmware > "
            "'Supports binary G-code')") from exc


def read_container(path: str | os.PathLike, *, strict: bool = True):
    """Read a G-code file and, for binary G-code, its decoded container.

    Returns
    -------
    (Program, BinaryGCode or None)
        The parsed program (``config`` from the slicer metadata for a binary file) and the container
        (None for a text file), for :func:`encode_like`.
    """
    raw = _read_bytes(path)
    if raw[:4] != BINARY_MAGIC:
        return parse_bytes(raw, strict=strict), None
    container = _decode_binary(raw, os.fspath(path))
    program = parse_bytes(container.gcode_bytes, strict=strict)
    meta = container.slicer_config
    if meta:
        program = dataclasses.replace(program, config={**meta, **program.config})
    producer = container.metadata_of(_block_type("FILE_METADATA")).get("Producer", "")
    if program.dialect.slicer == "unknown" and producer:
        slicer, _, version = producer.partition(" ")
        program = dataclasses.replace(program, dialect=Dialect(slicer, version, program.dialect.family))
    return program, container


def _read_bytes(path: str | os.PathLike) -> bytes:
    """Return the file's bytes; a missing or unreadable file is a one-line :class:`GCodeParseError`."""
    from loadpath.files import NotRegularError, read_regular

    where = os.fspath(path)
    try:
        return read_regular(path)
    except NotRegularError as exc:
        raise GCodeParseError(f"{where} {exc}; give the path of a .gcode file") from None
    except FileNotFoundError:
        raise GCodeParseError(f"{where} does not exist; check the path of the G-code file") from None
    except IsADirectoryError:
        raise GCodeParseError(
            f"{where} is a folder, not a G-code file; give the path of a .gcode file"
        ) from None
    except OSError as exc:
        raise GCodeParseError(f"cannot read {where} ({exc.strerror}); check its permissions") from None


def _block_type(name: str):
    """Look up a :class:`loadpath.gcode.bgcode.BlockType` by name (imported on use)."""
    from loadpath.gcode import bgcode

    return bgcode.BlockType[name]


def encode_like(container, text: bytes) -> bytes:
    """Write new G-code text in the format it was read from.

    Unchanged for text files (``container`` None); binary G-code with the container's metadata,
    thumbnails and compression otherwise.
    """
    if container is None:
        return text
    from loadpath.gcode import bgcode

    return bgcode.encode(container, text)


def parse(data: bytes | str, *, strict: bool = True) -> Program:
    """Parse G-code text into a :class:`Program`.

    Parameters
    ----------
    data : bytes or str
        The file's content (str is encoded as UTF-8; ``to_bytes()`` then returns those bytes).
    strict : bool
        Also check the structure (layer markers present, file not truncated).  Turn off for excerpts.

    Raises
    ------
    GCodeParseError, UnsupportedFlavorError
        One-line message naming what is wrong, where and the fix.
    """
    raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    return parse_bytes(decode_container(raw), strict=strict)


def read(path: str | os.PathLike, *, strict: bool = True) -> Program:
    """Read and parse a G-code file, text or binary (see :func:`parse`).  The file is only read."""
    return read_container(path, strict=strict)[0]
