"""Commands and words of every line, vectorized over the whole file.

A line is ``[blanks] COMMAND [WORDS] [; comment]``.  :func:`tokenize` returns, per line, the command
code (``G1`` -> :data:`G` + 1, ``M83`` -> :data:`M` + 83, ``T0`` -> :data:`T`), where its comment
starts, and for motion-like commands (G0-G3, G10, G11, G28, G92) the values of the words
``X Y Z E F I J R`` (NaN when absent) with a bit mask of which words are present.

Words are found in a (line x column) byte matrix of those lines' code parts, so a word's line is its
row and no per-word search is needed; their numbers go through :mod:`loadpath.gcode.numbers`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats, Ints
from loadpath.errors import GCodeParseError
from loadpath.gcode.lines import LineIndex
from loadpath.gcode.numbers import parse_numbers
from numpy.lib.stride_tricks import sliding_window_view

__all__ = [
    "Tokens",
    "tokenize",
    "G",
    "M",
    "T",
    "NO_COMMAND",
    "OTHER",
    "SUBCODE",
    "LETTERS",
    "BIT",
    "WORD_COMMANDS",
]

G, M, T = 10_000, 20_000, 30_000
"""Command code bases: ``G1`` is ``G + 1``, ``M486`` is ``M + 486``, ``T1`` is ``T + 1``."""
NO_COMMAND = -1  #: blank or comment-only line
OTHER = -2  #: a line whose first word is not G/M/T + number (Klipper macros, ``EXCLUDE_OBJECT_*``, ...)
SUBCODE = -3  #: a G/M command with a sub-code (``M862.3``, ``G92.1``): passed through, not interpreted

LETTERS = "XYZEFIJR"
"""Words read from motion-like lines, in the order of their bits in ``Tokens.present``."""
BIT = {c: 1 << i for i, c in enumerate(LETTERS)}

WORD_COMMANDS = (G + 0, G + 1, G + 2, G + 3, G + 10, G + 11, G + 28, G + 92)
"""Commands whose words are read."""

_MAX_ROW = 256  # code parts longer than this are read by the slow path
_ROW_BUCKETS = (32, 48, 64, 128, _MAX_ROW)  # matrix widths: narrow rows cost less


@dataclass(frozen=True)
class Tokens:
    """Per-line commands and words.

    Attributes
    ----------
    cmd : (n_lines,) int32
        Command code (:data:`G` + n, :data:`M` + n, :data:`T` + n) or :data:`NO_COMMAND`,
        :data:`OTHER`, :data:`SUBCODE`.
    code_end : (n_lines,) int64
        Byte offset where the line's code ends (its ``;`` comment or its end).
    comment : (n_lines,) bool
        The line has a ``;`` comment (possibly after code).
    values : dict of str -> (n_lines,) float64
        Value of each word of :data:`LETTERS` on motion-like lines; NaN where absent.
    present : (n_lines,) uint16
        Bit mask (:data:`BIT`) of the words present on each motion-like line.
    other_words : (n_lines,) bool
        A ``G10``/``G11`` line carries words (``G10 P1 L2`` sets a tool offset in RepRapFirmware; it
        is not a firmware retraction).  Only set on G10/G11 lines.
    """

    cmd: np.ndarray
    code_end: Ints
    comment: np.ndarray
    values: dict[str, Floats]
    present: np.ndarray
    other_words: np.ndarray


def _commands(idx: LineIndex) -> tuple[np.ndarray, Ints]:
    """Command code per line and the offset just after the command token."""
    buf, f_all, e_all = idx.buf, idx.first, idx.ends
    n = len(e_all)
    # fast path: the bulk of a slicer's lines start with 'G1 ' or 'G0 ' (first 3 bytes as one integer)
    head = np.ndarray(shape=(len(buf) - 4,), dtype="<u4", buffer=buf, strides=(1,))[f_all] & np.uint32(
        0xFFFFFF
    )
    g1 = (head == _G1_SP) | (head == _G1_TAB)
    g0 = (head == _G0_SP) | (head == _G0_TAB)
    cmd = np.full(n, OTHER, dtype=np.int32)
    after_all = f_all.copy()
    cmd[g1], cmd[g0] = G + 1, G + 0
    after_all[g1 | g0] += 2
    rest = np.flatnonzero(~(g1 | g0))
    f, e = f_all[rest], e_all[rest]
    n = len(rest)
    w = np.ascontiguousarray(sliding_window_view(buf, 7)[f].T)  # (7, n): the first bytes of each line
    room = np.minimum(e - f, 7).astype(np.uint8)
    up = w[0] & np.uint8(0xDF)
    base = np.zeros(n, dtype=np.int32)
    base[up == 71] = G
    base[up == 77] = M
    base[up == 84] = T
    base[room == 0] = 0
    alive = base > 0
    num = np.zeros(n, dtype=np.int32)
    ndig = np.zeros(n, dtype=np.uint8)
    for k in range(1, 6):  # up to 5 digits
        d = w[k] - np.uint8(48)
        alive &= (d < 10) & (room > k)
        num = num * np.where(alive, 10, 1).astype(np.int32) + d * alive
        ndig += alive
    after = f + 1 + ndig
    nxt = np.where(room > 1 + ndig, w[np.minimum(1 + ndig, 6), np.arange(n)], 32)
    sub_cmd = np.full(n, OTHER, dtype=np.int32)
    ok = (base > 0) & (ndig > 0)
    sub_cmd[ok] = base[ok] + num[ok]
    sub_cmd[ok & (nxt == 46)] = SUBCODE
    sub_cmd[(room == 0) | (w[0] == 59)] = NO_COMMAND
    cmd[rest] = sub_cmd
    after_all[rest] = np.where(ok, after, f)
    return cmd, after_all


def tokenize(idx: LineIndex) -> Tokens:
    """Commands of all lines and the words of motion-like lines (see the module docstring).

    Raises
    ------
    GCodeParseError
        A motion word without a valid number (``G1 X`` or ``G1 X1.2.3``), naming the line.
    """
    buf, n = idx.buf, idx.n_lines
    nbytes = int(idx.starts[-1])
    cmd, code_start = _commands(idx)
    # comments: first ';' of each line
    semis = np.flatnonzero(buf[:nbytes] == 59)
    code_end = idx.ends.copy()
    comment = np.zeros(n, dtype=bool)
    if len(semis):
        line_of = np.searchsorted(idx.starts, semis, side="right") - 1
        first = np.ones(len(semis), dtype=bool)
        first[1:] = line_of[1:] != line_of[:-1]
        line_of, pos = line_of[first], semis[first]
        inside = pos < idx.ends[line_of]
        code_end[line_of[inside]] = pos[inside]
        comment[line_of[inside]] = True
    values: dict[str, Floats] = {}
    present = np.zeros(n, dtype=np.uint16)
    other = np.zeros(n, dtype=bool)
    g_code = cmd - G
    lut = np.zeros(100, dtype=bool)
    lut[[c - G for c in WORD_COMMANDS]] = True
    sel = np.flatnonzero((g_code >= 0) & (g_code < 100) & lut[np.clip(g_code, 0, 99)])
    if len(sel):
        rows_len = code_end[sel] - code_start[sel]
        lo = 0
        for width in _ROW_BUCKETS:
            part = sel[(rows_len > lo) & (rows_len <= width)]
            lo = width
            if len(part):
                _words(
                    buf,
                    part,
                    code_start[part],
                    code_end[part],
                    width,
                    values,
                    present,
                    cmd[part] == G + 28,
                    (idx.starts, idx.ends),
                )
        long_rows = sel[rows_len > _MAX_ROW]
        if len(long_rows):
            _words_slow(buf, long_rows, code_start, code_end, values, present, other)
    for c in LETTERS:  # letters never written: a shared read-only NaN column
        if c not in values:
            values[c] = np.broadcast_to(np.float64(np.nan), (n,))
    # G10/G11 with words (G10 P1 L2: tool offsets in RepRapFirmware) are not firmware retraction
    for i in np.flatnonzero((cmd == G + 10) | (cmd == G + 11)).tolist():
        code = buf[code_start[i] : code_end[i]].tobytes().upper()
        other[i] = any(65 <= ch <= 90 for ch in code)
    return Tokens(
        cmd=cmd, code_end=code_end, comment=comment, values=values, present=present, other_words=other
    )


_G1_SP, _G1_TAB, _G0_SP, _G0_TAB = (int.from_bytes(b, "little") for b in (b"G1 ", b"G1\t", b"G0 ", b"G0\t"))
_ROW16 = np.arange(_MAX_ROW, dtype=np.uint16)[None, :]
_ENDS_WORD = np.zeros(256, dtype=bool)
_ENDS_WORD[[32, 9, 42] + list(range(65, 91)) + list(range(97, 123))] = True
_LETTER_CODE = np.zeros(256, dtype=np.uint8)
for _i, _c in enumerate(LETTERS):
    _LETTER_CODE[ord(_c)] = _i + 1
    _LETTER_CODE[ord(_c.lower())] = _i + 1


def _words(
    buf: np.ndarray,
    lines: Ints,
    start: Ints,
    end: Ints,
    width: int,
    values: dict[str, Floats],
    present: np.ndarray,
    bare_allowed: np.ndarray,
    line_bounds: tuple[Ints, Ints],
) -> None:
    """Words of ``lines`` whose code part (``start:end``) is at most ``width`` bytes.

    ``bare_allowed`` (per line of ``lines``): a letter without number is valid (``G28 X Y``).
    """
    # one V<width> item per line from an overlapping view: a gather twice as fast as sliding_window_view
    win = np.ndarray(shape=(len(buf) - width,), dtype=f"V{width}", buffer=buf, strides=(1,))
    chunk = max(1, (1 << 22) // width)
    for a in range(0, len(lines), chunk):
        ln, s, e = lines[a : a + chunk], start[a : a + chunk], end[a : a + chunk]
        bare_ok = bare_allowed[a : a + chunk]
        mat = win[s].view(np.uint8).reshape(len(s), width)  # (rows, width)
        inside = _ROW16[:, :width] < (e - s).astype(np.uint16)[:, None]
        up = mat & np.uint8(0xDF)  # ASCII letters to upper case; digits, '.', '-', ' ' map below 'A'
        known = (
            ((up - np.uint8(88)) < 3) | ((up - np.uint8(69)) < 2) | ((up - np.uint8(73)) < 2) | (up == 82)
        ) & inside
        flat = np.flatnonzero(known)
        ci, cj = np.divmod(flat, width)  # row, column (row-major: a repeated word's last copy comes last)
        if not len(cj):
            continue
        pos = s[ci] + cj + 1
        val, length = parse_numbers(buf, pos, e[ci])
        after = pos + length
        # a number must be followed by the end of the code, a blank, another letter or a checksum
        ok_end = (after >= e[ci]) | _ENDS_WORD[buf[after]]
        line_no = ln[ci]
        letter = _LETTER_CODE[mat.ravel()[flat]]
        bad = (length <= -2) | ((length > 0) & ~ok_end) | ((length == 0) & ~bare_ok[ci])
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            what = ("has no number" if length[i] == 0 else "has a number too large for any printer"
                    if length[i] == -3 else "has a malformed number")
            raise GCodeParseError(
                f"word {LETTERS[letter[i] - 1]!r} {what}; fix or remove the line (G-code numbers are plain "
                "decimals such as 12.5 or -.04)",
                line_no=int(line_no[i]) + 1,
                text=buf[line_bounds[0][line_no[i]] : line_bounds[1][line_no[i]]]
                .tobytes()
                .decode("utf-8", "replace"),
            )
        rows = len(ln)
        grid = np.full((len(LETTERS), rows), np.nan)
        seen = np.zeros((len(LETTERS), rows), dtype=bool)
        grid[letter - 1, ci] = val  # a repeated word: the last copy is written last and wins
        seen[letter - 1, ci] = True
        bits = np.zeros(rows, dtype=np.uint16)
        for j, c in enumerate(LETTERS):
            if seen[j].any():  # each line sits in one chunk: its row of the grid is its final value
                if c not in values:
                    values[c] = np.full(len(present), np.nan)
                values[c][ln] = grid[j]
                bits |= seen[j].astype(np.uint16) << np.uint16(j)
        present[ln] |= bits


def _words_slow(
    buf: np.ndarray,
    lines: Ints,
    start: Ints,
    end: Ints,
    values: dict[str, Floats],
    present: np.ndarray,
    other: np.ndarray,
) -> None:
    """Very long code parts (over 256 bytes): one Python pass per line."""
    raw = buf.tobytes()
    for ln in lines:
        text = raw[start[ln] : end[ln]].decode("ascii", "replace").upper()
        i = 0
        while i < len(text):
            ch = text[i]
            if "A" <= ch <= "Z":
                j = i + 1
                while j < len(text) and (text[j] in "0123456789.+-"):
                    j += 1
                if ch in LETTERS:
                    if ch not in values:
                        values[ch] = np.full(len(present), np.nan)
                    try:
                        values[ch][ln] = float(text[i + 1 : j]) if j > i + 1 else np.nan
                    except ValueError:
                        raise GCodeParseError(
                            f"word {ch!r} has a malformed number; fix or remove the line", line_no=int(ln) + 1
                        ) from None
                    if np.isinf(values[ch][ln]):
                        raise GCodeParseError(
                            f"word {ch!r} has a number too large for any printer ({j - i - 1} digits); fix or "
                            "remove the line", line_no=int(ln) + 1)
                    present[ln] |= np.uint16(BIT[ch])
                else:
                    other[ln] = True
                i = j
            else:
                i += 1
