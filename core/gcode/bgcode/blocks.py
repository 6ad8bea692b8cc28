"""Binary G-code (``.bgcode``) container: codes, block headers, checksums, compression.

The format is Prusa's public specification (``prusa3d/libbgcode: doc/specifications.md``). Facts the
specification leaves implicit were read from it and from libbgcode's behaviour (never its code) and
are pinned by the interop tests in ``tests/gcode/test_bgcode_reference.py``:

- all integers are little-endian;
- a block is ``header | parameters | data | checksum``; the header is 8 bytes (type, compression,
  uncompressed size) and 12 bytes when compressed (plus the compressed size);
- the CRC32 (zlib's polynomial, stored little-endian) covers the block header, the parameters and
  the data, in that order;
- Deflate data are zlib streams (with the 2-byte zlib header), written at zlib's default level;
- Heatshrink data are raw heatshrink streams (no framing), window 2^11 or 2^12, lookahead 2^4.

This module knows nothing about what a block means; :mod:`loadpath.gcode.bgcode.container` does.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from enum import IntEnum
from typing import TypeVar

from loadpath.errors import GCodeParseError, UnsupportedFlavorError
from loadpath.gcode.bgcode import heatshrink

__all__ = [
    "MAGIC",
    "VERSION",
    "BlockType",
    "ChecksumType",
    "Compression",
    "GCodeEncoding",
    "MetadataEncoding",
    "ThumbnailFormat",
    "RawBlock",
    "read_file_header",
    "iter_blocks",
    "write_file_header",
    "write_block",
    "compress",
    "decompress",
    "DISABLE_HINT",
]

_E = TypeVar("_E", bound=IntEnum)
MAGIC = b"GCDE"
VERSION = 1  # the only version the specification defines
_FILE_HEADER = struct.Struct("<4sIH")  # magic, version, checksum type: 10 bytes
_BLOCK_HEADER = struct.Struct("<HHI")  # type, compression, uncompressed size: 8 bytes
_U32 = struct.Struct("<I")

DISABLE_HINT = (
    "or turn binary G-code off in PrusaSlicer (Printer Settings > General > Firmware > "
    "'Supports binary G-code') and slice again"
)


class BlockType(IntEnum):
    """Block type codes of the specification."""

    FILE_METADATA = 0
    GCODE = 1
    SLICER_METADATA = 2
    PRINTER_METADATA = 3
    PRINT_METADATA = 4
    THUMBNAIL = 5


class ChecksumType(IntEnum):
    """Checksum codes of the file header."""

    NONE = 0
    CRC32 = 1


class Compression(IntEnum):
    """Block compression codes."""

    NONE = 0
    DEFLATE = 1
    HEATSHRINK_11_4 = 2
    HEATSHRINK_12_4 = 3


class GCodeEncoding(IntEnum):
    """Encoding codes of G-code blocks."""

    NONE = 0
    MEATPACK = 1
    MEATPACK_COMMENTS = 2


class MetadataEncoding(IntEnum):
    """Encoding codes of metadata blocks (JSON: PrusaSlicer 3's second slicer-metadata block)."""

    INI = 0
    JSON = 1


class ThumbnailFormat(IntEnum):
    """Image formats of thumbnail blocks."""

    PNG = 0
    JPG = 1
    QOI = 2


_PARAMS_SIZE = {t: 2 for t in BlockType} | {BlockType.THUMBNAIL: 6}
_HEATSHRINK = {Compression.HEATSHRINK_11_4: 11, Compression.HEATSHRINK_12_4: 12}
_LOOKAHEAD = 4


@dataclass(frozen=True)
class RawBlock:
    """One block as stored: header fields, raw parameters and the (still compressed) data.

    Attributes
    ----------
    index : int
        0-based position among the file's blocks (for messages).
    offset : int
        Byte offset of the block header in the file.
    type : BlockType
    compression : Compression
    uncompressed_size : int
        Size in bytes of the data once decompressed.
    params : bytes
        The block parameters (2 bytes: encoding; 6 bytes for thumbnails: format, width, height).
    data : bytes
        The block data exactly as stored (compressed when ``compression`` is not NONE).
    """

    index: int
    offset: int
    type: BlockType
    compression: Compression
    uncompressed_size: int
    params: bytes
    data: bytes

    def where(self) -> str:
        """Describe the block for an error message."""
        return f"block {self.index} ({self.type.name.lower()}, offset {self.offset})"


def _enum(cls: type[_E], value: int, what: str, where: str) -> _E:
    try:
        return cls(value)
    except ValueError:
        known = ", ".join(f"{m.value} {m.name.lower()}" for m in cls)
        raise UnsupportedFlavorError(
            f"binary G-code {where}: unknown {what} {value} (known: {known}); update loadpath "
            + DISABLE_HINT
        ) from None


def read_file_header(data: bytes | memoryview) -> tuple[int, ChecksumType]:
    """Check the 10-byte file header.

    Returns
    -------
    version : int
    checksum : ChecksumType

    Raises
    ------
    GCodeParseError
        Not a binary G-code file (wrong magic) or shorter than the header.
    UnsupportedFlavorError
        A version or checksum type this reader does not know.
    """
    if len(data) < _FILE_HEADER.size or bytes(data[:4]) != MAGIC:
        raise GCodeParseError(
            f"not a binary G-code file: it starts with {bytes(data[:4])!r}, not {MAGIC!r}; "
            "pass the .bgcode file PrusaSlicer wrote, unchanged"
        )
    _, version, checksum = _FILE_HEADER.unpack_from(data, 0)
    if version != VERSION:
        raise UnsupportedFlavorError(
            f"binary G-code version {version} is not supported (loadpath reads version {VERSION}); "
            "update loadpath " + DISABLE_HINT
        )
    return version, _enum(ChecksumType, checksum, "checksum type", "file header")


def iter_blocks(
    data: bytes | memoryview, checksum: ChecksumType, verify: bool = True
) -> Iterator[RawBlock]:
    """Yield the :class:`RawBlock` s after the file header, checking sizes and checksums.

    Parameters
    ----------
    data : bytes
        The whole file.
    checksum : ChecksumType
        From :func:`read_file_header`.
    verify : bool
        Compare each block's CRC32 with the stored one.

    Raises
    ------
    GCodeParseError
        Truncated file or checksum mismatch.
    UnsupportedFlavorError
        Unknown block type or compression.
    """
    view = memoryview(data)
    n = len(view)
    crc_size = 4 if checksum == ChecksumType.CRC32 else 0
    pos = _FILE_HEADER.size
    index = 0
    while pos < n:
        where = f"block {index} (offset {pos})"
        if pos + _BLOCK_HEADER.size > n:
            raise _truncated(where, pos + _BLOCK_HEADER.size, n)
        type_code, comp_code, usize = _BLOCK_HEADER.unpack_from(view, pos)
        btype = _enum(BlockType, type_code, "block type", where)
        comp = _enum(Compression, comp_code, "compression", where)
        head = _BLOCK_HEADER.size
        size = usize
        if comp != Compression.NONE:
            if pos + head + 4 > n:
                raise _truncated(where, pos + head + 4, n)
            size = _U32.unpack_from(view, pos + head)[0]
            head += 4
        psize = _PARAMS_SIZE[btype]
        end = pos + head + psize + size
        if end + crc_size > n:
            raise _truncated(f"block {index} ({btype.name.lower()}, offset {pos})", end + crc_size, n)
        block = RawBlock(
            index, pos, btype, comp, usize,
            bytes(view[pos + head : pos + head + psize]), bytes(view[pos + head + psize : end]),
        )
        if crc_size and verify:
            stored = _U32.unpack_from(view, end)[0]
            computed = zlib.crc32(view[pos:end])
            if stored != computed:
                raise GCodeParseError(
                    f"binary G-code {block.where()}: CRC32 mismatch (stored {stored:#010x}, computed "
                    f"{computed:#010x}): the file is damaged; slice and export it again"
                )
        yield block
        pos = end + crc_size
        index += 1


def _truncated(where: str, needed: int, size: int) -> GCodeParseError:
    return GCodeParseError(
        f"binary G-code truncated: {where} needs {needed} bytes but the file has {size}; "
        "the file is incomplete, export it again"
    )


def write_file_header(checksum: ChecksumType, version: int = VERSION) -> bytes:
    """Return the 10-byte file header."""
    return _FILE_HEADER.pack(MAGIC, version, int(checksum))


def write_block(
    btype: BlockType, compression: Compression, params: bytes, payload: bytes, checksum: ChecksumType
) -> bytes:
    """Compress ``payload`` and return the whole block (header, params, data, checksum)."""
    data = compress(payload, compression)
    header = _BLOCK_HEADER.pack(int(btype), int(compression), len(payload))
    if compression != Compression.NONE:
        header += _U32.pack(len(data))
    block = b"".join((header, params, data))
    if checksum == ChecksumType.CRC32:
        block += _U32.pack(zlib.crc32(block))
    return block


def compress(payload: bytes, compression: Compression) -> bytes:
    """Compress a block payload with the block's algorithm."""
    if compression == Compression.NONE:
        return payload
    if compression == Compression.DEFLATE:
        return zlib.compress(payload)  # zlib stream, default level, as PrusaSlicer writes
    return heatshrink.compress(payload, _HEATSHRINK[compression], _LOOKAHEAD)


def decompress(block: RawBlock) -> bytes:
    """Return the block's data decompressed, checked against the declared size."""
    comp = block.compression
    if comp == Compression.NONE:
        out = block.data
    elif comp == Compression.DEFLATE:
        try:
            out = zlib.decompress(block.data)
        except zlib.error as exc:
            raise GCodeParseError(
                f"binary G-code {block.where()}: Deflate data are corrupt ({exc}); export the file again"
            ) from None
    else:
        out = heatshrink.decompress(block.data, _HEATSHRINK[comp], _LOOKAHEAD)
    if len(out) != block.uncompressed_size:
        raise GCodeParseError(
            f"binary G-code {block.where()}: data decompress to {len(out)} bytes, the header says "
            f"{block.uncompressed_size}; the file is damaged, export it again"
        )
    return out
