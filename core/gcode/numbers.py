"""Vectorized decimal parsing: the numbers of G-code words, straight from the file's bytes.

Python's ``float()`` costs about 0.3 us per number, too slow for a million-line file with three
numbers a line.  Here each number is read from a 16-byte window of the byte buffer (gathered as
one ``V16`` item per number from an overlapping view, then transposed so every step is a contiguous
uint8 vector operation over all numbers at once):

1. classify the window's bytes (digit, ``.``, sign) and find each number's length and the digits
   after its dot, column by column;
2. combine the digits pairwise (2 -> 4 -> 8 -> 16 digits) into an exact integer mantissa ``m``,
   tracking how many digits each half holds;
3. ``value = +-m / 10**frac``.  ``m`` has at most 15 digits, so it and ``10**frac`` are exact
   doubles and the division is correctly rounded: the result equals ``float(text)`` bit for bit.

Numbers that do not fit (more than 15 digits, longer than the window) are parsed with ``float()``.
G-code has no exponent notation, so ``e``/``E`` ends a number (it is the extruder word).
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Floats, Ints

__all__ = ["parse_numbers", "WINDOW"]

WINDOW = 16
"""Bytes read per number (sign, digits and dot); longer numbers take the slow path."""

_CHUNK = 1 << 15
_COL = np.arange(WINDOW, dtype=np.uint8)[:, None]
_P10_U32 = (10 ** np.arange(9)).astype(np.uint32)
_P10_U64 = (10 ** np.arange(17)).astype(np.uint64)
_P10_F = 10.0 ** np.arange(23)
_MAX_DIGITS = 15  # 10**15 < 2**53: the mantissa is an exact double


def parse_numbers(buf: np.ndarray, starts: Ints, limit: Ints) -> tuple[Floats, Ints]:
    """Parse the decimal numbers that start at ``starts`` in ``buf``.

    Parameters
    ----------
    buf : (n_bytes + pad,) uint8
        The file's bytes, padded with at least :data:`WINDOW` zero bytes.
    starts : (k,) int
        Offset of each number's first byte (the byte after its word letter).
    limit : (k,) int
        Offset where the number's field must end at the latest (end of the code part of its line).

    Returns
    -------
    values : (k,) float64
        The numbers; NaN where no number starts there (a bare word letter).
    length : (k,) int64
        Bytes each number occupies; 0 when no number starts there (a bare letter), -2 when the bytes
        look like a number but are not one (``-``, ``.``, ``1.2.3``), -3 when the number overflows a double
        (309 or more digits).  A valid number is followed by a
        byte that is not part of it: the caller checks what follows (space, another word, end of code).
    """
    k = len(starts)
    values = np.zeros(k)
    length = np.zeros(k, dtype=np.int64)
    win = np.ndarray(shape=(len(buf) - WINDOW,), dtype=f"V{WINDOW}", buffer=buf, strides=(1,))
    for a in range(0, k, _CHUNK):
        b = min(a + _CHUNK, k)
        values[a:b], length[a:b] = _parse_chunk(win, starts[a:b], limit[a:b])
    slow = np.flatnonzero(length < 0)
    if len(slow):
        raw = buf.tobytes()
        for i in slow:  # numbers longer than the window or with more than 15 digits: rare
            s, lim = int(starts[i]), int(limit[i])
            j = s + (raw[s : s + 1] in (b"-", b"+"))
            while j < lim and raw[j : j + 1] in b"0123456789.":
                j += 1
            try:
                values[i] = float(raw[s:j])
                length[i] = j - s if np.isfinite(values[i]) else -3  # 309+ digits overflow to inf
            except ValueError:
                values[i] = np.nan
                length[i] = -2 if j > s else 0
    return values, length


def _parse_chunk(win: np.ndarray, p: Ints, lim: Ints) -> tuple[Floats, Ints]:
    w = np.ascontiguousarray(
        win[p].view(np.uint8).reshape(-1, WINDOW).T
    )  # (WINDOW, k): one row per column of the numbers
    room = np.minimum(lim - p, WINDOW).astype(np.uint8)  # bytes that may belong to the number
    c0 = w[0]
    neg = c0 == 45
    sign = neg | (c0 == 43)
    d = w - np.uint8(48)
    isd = d < 10
    isdot = w == 46
    # column scan: run of number bytes from column 0 (a sign only there), digits after the dot
    alive = (isd[0] | isdot[0] | sign) & (room > 0)
    length = alive.astype(np.uint8)
    seen_dot = isdot[0] & alive
    ndots = seen_dot.astype(np.uint8)
    frac = np.zeros(len(p), dtype=np.uint8)
    for j in range(1, WINDOW):
        if j % 4 == 0 and not alive.any():
            break
        alive &= (isd[j] | isdot[j]) & (room > j)
        length += alive
        dig_j = alive & isd[j]
        frac += dig_j & seen_dot
        dot_j = alive & isdot[j]
        ndots += dot_j
        seen_dot |= dot_j
    inside = _COL < length
    dg = isd & inside
    v = d * dg
    n = dg.view(np.uint8)
    # pairwise combination of digit groups: value(AB) = value(A) * 10**digits(B) + value(B)
    nb = n[1::2]
    v = v[0::2] * (np.uint8(1) + np.uint8(9) * nb) + v[1::2]  # <= 99
    n = n[0::2] + nb
    nb = n[1::2].astype(np.uint16)
    v = v[0::2].astype(np.uint16) * (1 + 9 * nb + 81 * (nb >> 1)) + v[1::2]  # 10**nb, nb <= 2; <= 9999
    n = n[0::2] + n[1::2]
    v = v[0::2].astype(np.uint32) * _P10_U32[n[1::2]] + v[1::2]  # <= 10**8 - 1
    n = n[0::2] + n[1::2]
    mant = v[0].astype(np.uint64) * _P10_U64[n[1]] + v[1]
    ndig = n[0].astype(np.int64) + n[1]
    values = mant.astype(np.float64) / _P10_F[frac]
    np.negative(values, out=values, where=neg)
    out_len = length.astype(np.int64)
    bad = (ndig == 0) | (ndots > 1)
    values[bad] = np.nan
    out_len[bad] = np.where(length[bad] > 0, -2, 0)
    # too long for the window (still alive at its end) or too many digits: slow path
    out_len[(alive & (room >= WINDOW)) | (ndig > _MAX_DIGITS)] = -1
    return values, out_len
