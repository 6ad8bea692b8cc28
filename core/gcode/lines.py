"""Byte-level line index of a G-code file, and the checks that it is text at all.

Everything here works on the raw bytes with numpy, so a file is never split into Python strings:
the parser keeps the original bytes and addresses each line by its byte offsets, which is what makes
``Program.to_bytes()`` lossless (line endings, trailing spaces and encoding included).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Ints
from loadpath.errors import GCodeParseError

__all__ = ["LineIndex", "index_lines", "check_text", "PAD"]

PAD = 64
"""Zero bytes appended to the byte buffer so fixed-width windows never read past its end."""


@dataclass(frozen=True)
class LineIndex:
    r"""Where each line sits in the file's bytes.

    Attributes
    ----------
    buf : (n_bytes + PAD,) uint8
        The file's bytes followed by :data:`PAD` zero bytes.
    starts : (n_lines + 1,) int64
        Byte offset where each line starts; ``starts[-1] == n_bytes``. Line ``i`` including its line
        ending is ``data[starts[i]:starts[i + 1]]``.
    ends : (n_lines,) int64
        Byte offset where each line's content ends (before ``\r\n`` or ``\n``).
    first : (n_lines,) int64
        Offset of the first byte that is not a space or tab (``== ends`` for blank lines).
    """

    buf: np.ndarray
    starts: Ints
    ends: Ints
    first: Ints

    @property
    def n_lines(self) -> int:
        """Number of lines (a last line without a line ending counts)."""
        return len(self.ends)


def check_text(data: bytes) -> None:
    """Raise :class:`GCodeParseError` unless ``data`` is non-empty UTF-8 text without NUL bytes.

    The message names the first offending line and the fix.
    """
    if not data.strip():
        raise GCodeParseError(
            "the file is empty (or blank): there is no G-code to process; export the G-code from the "
            "slicer again"
        )
    nul = data.find(b"\0")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        raise GCodeParseError(
            f"the file is not text: byte {nul} is a NUL byte; pass the .gcode file the slicer wrote (not a "
            ".3mf, .stl, image or archive)",
            line_no=line,
        )
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise GCodeParseError(
            f"the file is not UTF-8 text: byte {exc.start} is 0x{data[exc.start]:02x}; pass the .gcode file "
            "the slicer wrote, or re-save it as UTF-8",
            line_no=line,
        ) from None


def index_lines(data: bytes) -> LineIndex:
    r"""Build the :class:`LineIndex` of ``data`` (vectorized; no per-line Python work).

    Lines end at ``\n``; a ``\r`` before it belongs to the line ending. A final line without
    ``\n`` is a line too.
    """
    n = len(data)
    buf = np.zeros(n + PAD, dtype=np.uint8)
    buf[:n] = np.frombuffer(data, dtype=np.uint8)
    nl = np.flatnonzero(buf[:n] == 10)
    if n and data[-1:] != b"\n":
        content_end = np.concatenate([nl, [n]])
    else:
        content_end = nl
    starts = np.zeros(len(content_end) + 1, dtype=np.int64)
    starts[0] = 0
    starts[1:] = content_end + 1
    starts[-1] = n
    ends = content_end.astype(np.int64)
    has_cr = (ends > starts[:-1]) & (buf[np.maximum(ends - 1, 0)] == 13)
    ends = ends - has_cr
    first = starts[:-1].copy()
    todo = np.flatnonzero((first < ends) & ((buf[first] == 32) | (buf[first] == 9)))
    while len(todo):  # leading blanks are rare: loop over the indentation depth, vectorized over lines
        first[todo] += 1
        todo = todo[(first[todo] < ends[todo]) & ((buf[first[todo]] == 32) | (buf[first[todo]] == 9))]
    return LineIndex(buf=buf, starts=starts, ends=ends, first=first)
