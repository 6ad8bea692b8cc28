"""Numbers as slicer text, many at once: the bytes :func:`loadpath.splice.emit.fmt` writes, from numpy.

The G-code writer spent most of its time formatting numbers one Python float at a time (issue 17,
``benchmarks/bench_splice.py``: 2.1 of 6.5 CPU seconds on the 100-layer specimen).  Here a column of
numbers becomes a matrix of ASCII digits with a mask of the characters kept, and a line of columns
(``"G1 X"``, x, ``" Y"``, y, ...) one flattened matrix: :func:`lines` returns every line's text from
one ``bytes`` built in C.

Exactness: ``"%.3f" % v`` rounds the double's exact binary value to 3 decimals.  The integer
``rint(v * 10**d)`` is the same number unless ``v * 10**d`` lies within its own rounding error of a
half; those few values are formatted by Python and read back, so every digit written is the one
:func:`~loadpath.splice.emit.fmt` would write.  Values that are not finite or not below
``1e15 / 10**d`` are refused (:func:`writable` tells; the writer formats those one at a time).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["Column", "writable", "number_column", "text_column", "lines"]

_HALF_MARGIN = 1e-9
"""Absolute part of the band around a half where ``rint(v * 10**d)`` is not trusted."""

_LIMIT = 1e15
"""Largest ``|v| * 10**d`` formatted from numpy (beyond it, Python formats)."""


class Column:
    """One column of a block of lines: characters ``(n, k) uint8`` and which are kept ``(n, k) bool``."""

    __slots__ = ("chars", "keep")

    def __init__(self, chars: np.ndarray, keep: np.ndarray) -> None:
        self.chars = chars
        self.keep = keep


def writable(values, decimals: int) -> bool:
    """Whether :func:`number_column` can write every value: finite, ``|v| * 10**decimals < 1e15``."""
    v = np.asarray(values, dtype=float)
    return bool(np.all(np.abs(v) * float(10**decimals) < _LIMIT))  # False for NaN and infinity too


def _scaled(values: np.ndarray, decimals: int) -> np.ndarray:
    """``values`` rounded to ``decimals`` as ``%.{decimals}f`` rounds them, times ``10**decimals``; int64."""
    s = values * float(10**decimals)
    if not np.all(np.abs(s) < _LIMIT):
        raise ValueError("number_column writes finite numbers below 1e15 / 10**decimals only")
    k = np.rint(s)
    frac = np.abs(s - np.trunc(s))
    doubt = np.abs(frac - 0.5) <= _HALF_MARGIN + np.abs(s) * 4e-16
    out = np.where(doubt, 0.0, k).astype(np.int64)
    if doubt.any():
        f = f"%.{decimals}f"
        for i in np.flatnonzero(doubt).tolist():
            out[i] = int((f % float(values[i])).replace(".", ""))
    return out


def number_column(values, decimals: int, leading_zero: bool = False) -> Column:
    """The text :func:`loadpath.splice.emit.fmt` gives each value, as a :class:`Column`.

    Parameters
    ----------
    values : (n,) float
        :func:`writable` ones (else ValueError).
    decimals : int
        Digits after the point before trailing zeros are dropped (3 for XYZ, 5 for E).
    leading_zero : bool
        ``0.5`` (Cura) rather than ``.5`` (PrusaSlicer).

    Returns
    -------
    Column
        Layout ``[sign][integer digits]["."][decimals digits]``, unused characters masked out.

    Examples
    --------
    >>> c = number_column([0.6, -0.04, 199.3680001, 0.0, 100.0, -0.0001], 3)
    >>> [bytes(r[m]).decode() for r, m in zip(c.chars, c.keep)]
    ['.6', '-.04', '199.368', '0', '100', '0']
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    k = _scaled(v, decimals)
    neg = k < 0
    a = np.abs(k)
    unit = 10**decimals
    ip, fp = a // unit, a % unit
    width = max(len(str(int(ip.max()))) if len(ip) else 1, 1)
    n = len(v)
    chars = np.empty((n, 1 + width + 1 + decimals), dtype=np.uint8)
    keep = np.zeros(chars.shape, dtype=bool)
    chars[:, 0] = ord("-")
    keep[:, 0] = neg
    # integer digits, most significant first: kept from the first non-zero one; a lone zero when
    # the integer part is zero and the number is (leading_zero) or rounds to zero
    if width <= _INT_DIGITS:  # the usual case (below 1000): looked up, not divided
        ich, ikeep = _digit_table(_INT_DIGITS, False)
        chars[:, 1 : 1 + width] = ich[ip, _INT_DIGITS - width :]
        keep[:, 1 : 1 + width] = ikeep[ip, _INT_DIGITS - width :]
    else:
        power = 10 ** np.arange(width - 1, -1, -1, dtype=np.int64)
        digits = (ip[:, None] // power[None, :]) % 10
        chars[:, 1 : 1 + width] = digits + ord("0")
        keep[:, 1 : 1 + width] = ip[:, None] >= power[None, :]
    lone = (ip == 0) & ((a == 0) | leading_zero)
    keep[:, width] |= lone
    chars[:, 1 + width] = ord(".")
    keep[:, 1 + width] = fp != 0
    if decimals:
        if decimals <= _FRACTION_DIGITS:
            fch, fkeep = _digit_table(decimals, True)
            chars[:, 2 + width :] = fch[fp]
            keep[:, 2 + width :] = fkeep[fp]
        else:
            fpow = 10 ** np.arange(decimals - 1, -1, -1, dtype=np.int64)
            fd = (fp[:, None] // fpow[None, :]) % 10
            chars[:, 2 + width :] = fd + ord("0")
            # kept up to the last non-zero digit
            nz = fd != 0
            last = decimals - 1 - np.argmax(nz[:, ::-1], axis=1)
            keep[:, 2 + width :] = (np.arange(decimals)[None, :] <= last[:, None]) & (fp != 0)[:, None]
    return Column(chars, keep)


_INT_DIGITS = 3
"""Integer parts below ``10**_INT_DIGITS`` take their digits from a table (:func:`_digit_table`)."""

_FRACTION_DIGITS = 5
"""Fractions of up to this many decimals take their digits from a table (5: 100,000 rows, 1 MB)."""


@lru_cache(maxsize=None)
def _digit_table(digits: int, fraction: bool) -> tuple[np.ndarray, np.ndarray]:
    """The characters ``(10**digits, digits) uint8`` of every integer below ``10**digits``, zero-padded,
    and which of them are written ``(10**digits, digits) bool``.

    Integer parts (``fraction`` False): from the first non-zero digit on (none for 0).  Fractions
    (``fraction`` True, the digits after the point): up to the last non-zero one (none for 0).
    The digits :func:`number_column` divided out one column at a time, made once per process
    (issue 17: the divisions were most of the column's time).
    """
    v = np.arange(10**digits, dtype=np.int64)
    power = 10 ** np.arange(digits - 1, -1, -1, dtype=np.int64)
    d = (v[:, None] // power[None, :]) % 10
    chars = (d + ord("0")).astype(np.uint8)
    if not fraction:
        keep = v[:, None] >= power[None, :]
    else:
        last = digits - 1 - np.argmax((d != 0)[:, ::-1], axis=1)
        keep = (np.arange(digits)[None, :] <= last[:, None]) & (v != 0)[:, None]
    chars.setflags(write=False)
    keep.setflags(write=False)
    return chars, keep


def text_column(text: str, n: int, keep=None) -> Column:
    """A constant text in every one of ``n`` lines (only in the lines ``keep``, when given)."""
    b = np.frombuffer(text.encode("ascii"), dtype=np.uint8)
    chars = np.broadcast_to(b, (n, len(b)))
    if keep is None:
        mask = np.ones((n, len(b)), dtype=bool)
    else:
        mask = np.repeat(np.asarray(keep, dtype=bool)[:, None], len(b), axis=1)
    return Column(chars, mask)


def lines(columns: list[Column]) -> list[str]:
    """The lines the columns make, left to right, one ``str`` per row.

    Parameters
    ----------
    columns : list of Column
        The same number of rows each.

    Returns
    -------
    list of str
    """
    n = columns[0].chars.shape[0]
    if n == 0:
        return []
    nl = Column(np.full((n, 1), ord("\n"), dtype=np.uint8), np.ones((n, 1), dtype=bool))
    chars = np.concatenate([c.chars for c in columns] + [nl.chars], axis=1)
    keep = np.concatenate([c.keep for c in columns] + [nl.keep], axis=1)
    return chars[keep].tobytes().decode("ascii").split("\n")[:-1]
