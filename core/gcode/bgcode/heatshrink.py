"""Heatshrink (LZSS) compression of binary G-code blocks: the one adapter over ``heatshrink2``.

Why a dependency instead of our own code: heatshrink is a sequential bit-level LZSS; a pure-Python
decoder runs at a few MB/s and an encoder (longest-match search over a 4 KiB window) far slower,
while ``heatshrink2`` binds the reference C library (atomicobject/heatshrink, the same code libbgcode
and the printers' firmware use) under the ISC licence, with wheels for CPython 3.10-3.13. Using the
same C encoder also makes our compressed blocks byte-identical to PrusaSlicer's. The justification
for the dependency is repeated beside it in ``setup.cfg``.

Stream format (for the record): raw heatshrink, no framing; each item is a flag bit, 1 = literal
byte (8 bits), 0 = back-reference (``window_sz2`` bits of offset - 1, then ``lookahead_sz2`` bits
of length - 1); bits are packed MSB first and the last byte is zero-padded.
"""

from __future__ import annotations

from types import ModuleType

from loadpath.errors import GCodeParseError, ToolMissingError

__all__ = ["compress", "decompress"]


def _lib() -> ModuleType:
    try:
        import heatshrink2
    except ImportError:  # pragma: no cover - heatshrink2 is an install requirement
        raise ToolMissingError(
            "heatshrink2 is not installed but binary G-code uses Heatshrink compression: "
            "pip install heatshrink2"
        ) from None
    return heatshrink2


def compress(data: bytes, window_sz2: int, lookahead_sz2: int) -> bytes:
    """Compress ``data`` into a raw heatshrink stream.

    Parameters
    ----------
    data : bytes
    window_sz2 : int
        Base-2 logarithm of the window (11 or 12 in binary G-code).
    lookahead_sz2 : int
        Base-2 logarithm of the longest match (4 in binary G-code).
    """
    if not data:
        return b""
    return bytes(_lib().encode(data, window_sz2=window_sz2, lookahead_sz2=lookahead_sz2))


def decompress(data: bytes, window_sz2: int, lookahead_sz2: int) -> bytes:
    """Decompress a raw heatshrink stream (the caller checks the size it expects)."""
    if not data:
        return b""
    try:
        return bytes(_lib().decode(data, window_sz2=window_sz2, lookahead_sz2=lookahead_sz2))
    except (RuntimeError, ValueError) as exc:
        raise GCodeParseError(
            f"Heatshrink {window_sz2}/{lookahead_sz2} data are corrupt ({exc}); export the file again"
        ) from None
