r"""Binary G-code (``.bgcode``, PrusaSlicer 2.7+): decode to text, encode back in the same format.

PrusaSlicer hands post-processing scripts a binary file when binary output is on
(``../shared/docs/slicer-conventions.md`` §10). :func:`decode` turns it into a :class:`BinaryGCode`:
the header fields, the metadata blocks (ordered key/value pairs), the thumbnails (image bytes), the
G-code text and the compression/encoding each block used. :func:`encode` writes a (processed) text
back with the same metadata, thumbnails and parameters. PrusaSlicer's own choice, used for new files,
is :data:`PRUSASLICER_PARAMS`.

Round trips:

- ``decode(encode(bg, text)).gcode == text`` byte for byte when the G-code encoding is NONE; with
  MeatPack it equals :func:`loadpath.gcode.bgcode.meatpack.normalize` of the text (MeatPack drops empty
  lines, end-of-line comments and spaces of ``G`` lines by design), so text that came out of
  :func:`decode` comes back unchanged.
- ``encode(decode(data))`` gives the same metadata and thumbnail blocks byte for byte, and G-code
  blocks that decode to the same text. The G-code blocks are byte-identical too (same zlib and
  heatshrink encoders, same 64 KiB blocks) unless the original had end-of-line comments, which
  MeatPack drops while the newline it had written before them survives (checked against libbgcode
  in ``tests/gcode/test_bgcode_reference.py``).

Use in a reader/writer (the G-code text of a binary file has no ``; prusaslicer_config`` block: the
configuration is :attr:`BinaryGCode.slicer_config`)::

    data = path.read_bytes()
    container = bgcode.decode(data) if bgcode.is_bgcode(data) else None
    text = container.gcode_bytes if container else data      # parse this
    ...
    out = bgcode.encode(container, new_text) if container else new_text   # binary stays binary

Example
-------
>>> from loadpath.gcode import bgcode
>>> bg = bgcode.new_container({"printer_model": "MK4S"}, {"estimated printing time (normal mode)": "1m"},
...                           {"layer_height": "0.2"})
>>> data = bgcode.encode(bg, "G1 X1 Y2 E0.5\n")
>>> bgcode.is_bgcode(data), bgcode.decode(data).gcode
(True, 'G1 X1 Y2 E0.5\n')
"""

from __future__ import annotations

import base64
import struct
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import IntEnum
from typing import TypeVar

import numpy as np
from loadpath.errors import GCodeParseError, UnsupportedFlavorError
from loadpath.gcode.bgcode import meatpack
from loadpath.gcode.bgcode.blocks import (
    DISABLE_HINT,
    MAGIC,
    VERSION,
    BlockType,
    ChecksumType,
    Compression,
    GCodeEncoding,
    MetadataEncoding,
    RawBlock,
    ThumbnailFormat,
    decompress,
    iter_blocks,
    read_file_header,
    write_block,
    write_file_header,
)

__all__ = [
    "BinaryGCode",
    "MetadataBlock",
    "Thumbnail",
    "GCodeBlockInfo",
    "BlockType",
    "ChecksumType",
    "Compression",
    "GCodeEncoding",
    "MetadataEncoding",
    "ThumbnailFormat",
    "PRUSASLICER_PARAMS",
    "GCODE_BLOCK_SIZE",
    "is_bgcode",
    "decode",
    "encode",
    "new_container",
    "to_ascii",
]

_E = TypeVar("_E", bound=IntEnum)
GCODE_BLOCK_SIZE = 65536  # PrusaSlicer's G-code cache: a block holds whole lines, at most this many bytes
_TEXT = ("utf-8", "surrogateescape")  # lossless bytes <-> str
_U16 = struct.Struct("<H")
_THUMB = struct.Struct("<HHH")

#: PrusaSlicer's parameters (``GCodeProcessor.cpp``): compression per block kind, G-code encoding,
#: metadata encoding, checksum.
PRUSASLICER_PARAMS = {
    BlockType.FILE_METADATA: Compression.NONE,
    BlockType.PRINTER_METADATA: Compression.NONE,
    BlockType.PRINT_METADATA: Compression.DEFLATE,
    BlockType.SLICER_METADATA: Compression.DEFLATE,
    BlockType.GCODE: Compression.HEATSHRINK_12_4,
    "gcode_encoding": GCodeEncoding.MEATPACK_COMMENTS,
    "metadata_encoding": MetadataEncoding.INI,
    "checksum": ChecksumType.CRC32,
}

_METADATA_ORDER = (BlockType.FILE_METADATA, BlockType.PRINTER_METADATA, BlockType.THUMBNAIL,
                   BlockType.PRINT_METADATA, BlockType.SLICER_METADATA, BlockType.GCODE)
_RANK = {t: i for i, t in enumerate(_METADATA_ORDER)}


@dataclass(frozen=True)
class MetadataBlock:
    """A metadata block.

    Attributes
    ----------
    kind : BlockType
        FILE_METADATA, PRINTER_METADATA, PRINT_METADATA or SLICER_METADATA.
    items : tuple of (str, str)
        Key/value pairs in file order (INI ``key=value`` lines). A JSON block holds one pair whose
        key is ``""`` and whose value is the JSON text.
    encoding : MetadataEncoding
    compression : Compression
    """

    kind: BlockType
    items: tuple[tuple[str, str], ...]
    encoding: MetadataEncoding = MetadataEncoding.INI
    compression: Compression = Compression.NONE

    def as_dict(self) -> dict[str, str]:
        """Return the pairs as a dict (a repeated key keeps its last value)."""
        return dict(self.items)

    def params(self) -> bytes:
        """Return the block parameters as stored (the encoding, uint16)."""
        return _U16.pack(int(self.encoding))

    def payload(self) -> bytes:
        """Return the uncompressed block data."""
        if self.encoding == MetadataEncoding.JSON:
            return "".join(v for _, v in self.items).encode(*_TEXT)
        return "".join(f"{k}={v}\n" for k, v in self.items).encode(*_TEXT)


@dataclass(frozen=True)
class Thumbnail:
    """A thumbnail block: image parameters and the image file's bytes (PNG, JPG or QOI)."""

    format: ThumbnailFormat
    width: int
    height: int
    data: bytes
    compression: Compression = Compression.NONE

    def params(self) -> bytes:
        """Return the block parameters as stored (format, width, height; uint16 each)."""
        return _THUMB.pack(int(self.format), self.width, self.height)


@dataclass(frozen=True)
class GCodeBlockInfo:
    """How one G-code block was stored: its compression, its encoding, its decoded text size (bytes)."""

    compression: Compression
    encoding: GCodeEncoding
    text_size: int


@dataclass(frozen=True)
class BinaryGCode:
    """A decoded binary G-code file.

    Attributes
    ----------
    version : int
        Format version from the file header (1).
    checksum : ChecksumType
    metadata : tuple of MetadataBlock
        In file order: file (optional), printer, print, slicer (one INI block; PrusaSlicer 3 adds a
        JSON one).
    thumbnails : tuple of Thumbnail
        In file order.
    gcode : str
        The G-code text of all G-code blocks, concatenated (bytes that are not UTF-8 are kept as
        surrogate escapes, so ``gcode.encode("utf-8", "surrogateescape")`` gives the exact bytes).
    gcode_blocks : tuple of GCodeBlockInfo
        Per G-code block, as found (empty for a new container).
    gcode_compression, gcode_encoding :
        Used by :func:`encode` for the G-code blocks: those of the input's first G-code block.
    """

    version: int
    checksum: ChecksumType
    metadata: tuple[MetadataBlock, ...]
    thumbnails: tuple[Thumbnail, ...] = ()
    gcode: str = ""
    gcode_blocks: tuple[GCodeBlockInfo, ...] = ()
    gcode_compression: Compression = Compression.HEATSHRINK_12_4
    gcode_encoding: GCodeEncoding = GCodeEncoding.MEATPACK_COMMENTS
    block_size: int = field(default=GCODE_BLOCK_SIZE, repr=False)

    def metadata_of(self, kind: BlockType) -> dict[str, str]:
        """All INI pairs of the blocks of one kind, as a dict ({} when there is none)."""
        out: dict[str, str] = {}
        for block in self.metadata:
            if block.kind == kind and block.encoding == MetadataEncoding.INI:
                out.update(block.items)
        return out

    @property
    def gcode_bytes(self) -> bytes:
        """The G-code text as the exact bytes stored in the file."""
        return self.gcode.encode(*_TEXT)

    @property
    def slicer_config(self) -> dict[str, str]:
        """PrusaSlicer's full configuration (the slicer metadata), key -> value."""
        return self.metadata_of(BlockType.SLICER_METADATA)


def is_bgcode(data: bytes | bytearray | memoryview) -> bool:
    """Tell whether ``data`` starts with the binary G-code magic ``GCDE``."""
    return bytes(data[:4]) == MAGIC


# ---------------------------------------------------------------------------------------- decode


def decode(data: bytes, verify_checksum: bool = True) -> BinaryGCode:
    """Read a binary G-code file.

    Parameters
    ----------
    data : bytes
        The whole file.
    verify_checksum : bool
        Check every block's CRC32 (when the file has checksums).

    Raises
    ------
    GCodeParseError
        Not binary G-code, truncated, damaged (checksum, compressed data), or blocks out of order.
    UnsupportedFlavorError
        A version, block type, compression or encoding this reader does not know.
    """
    version, checksum = read_file_header(data)
    metadata: list[MetadataBlock] = []
    thumbnails: list[Thumbnail] = []
    texts: list[bytes] = []
    infos: list[GCodeBlockInfo] = []
    rank = 0
    for block in iter_blocks(data, checksum, verify_checksum):
        r = _RANK[block.type]
        if r < rank:
            raise GCodeParseError(
                f"binary G-code {block.where()} comes after a later kind of block (the order is file, "
                "printer, thumbnail, print, slicer metadata, then G-code); export the file again"
            )
        rank = r
        if block.type == BlockType.GCODE:
            text, info = _decode_gcode(block)
            texts.append(text)
            infos.append(info)
        elif block.type == BlockType.THUMBNAIL:
            thumbnails.append(_decode_thumbnail(block))
        else:
            metadata.append(_decode_metadata(block))
    kinds = {m.kind for m in metadata}
    for needed in (BlockType.PRINTER_METADATA, BlockType.PRINT_METADATA, BlockType.SLICER_METADATA):
        if needed not in kinds:
            raise GCodeParseError(
                f"binary G-code has no {needed.name.lower().replace('_', ' ')} block (the specification "
                "requires it); export the file again from PrusaSlicer"
            )
    first = infos[0] if infos else GCodeBlockInfo(
        PRUSASLICER_PARAMS[BlockType.GCODE], PRUSASLICER_PARAMS["gcode_encoding"], 0
    )
    return BinaryGCode(
        version=version,
        checksum=checksum,
        metadata=tuple(metadata),
        thumbnails=tuple(thumbnails),
        gcode=b"".join(texts).decode(*_TEXT),
        gcode_blocks=tuple(infos),
        gcode_compression=first.compression,
        gcode_encoding=first.encoding,
    )


def _u16(block: RawBlock, what: str, cls: type[_E]) -> _E:
    value = _U16.unpack_from(block.params)[0]
    try:
        return cls(value)
    except ValueError:
        known = ", ".join(f"{m.value} {m.name.lower()}" for m in cls)
        raise UnsupportedFlavorError(
            f"binary G-code {block.where()}: unknown {what} {value} (known: {known}); update loadpath "
            + DISABLE_HINT
        ) from None


def _decode_metadata(block: RawBlock) -> MetadataBlock:
    encoding = _u16(block, "metadata encoding", MetadataEncoding)
    text = decompress(block).decode(*_TEXT)
    if encoding == MetadataEncoding.JSON:
        items: tuple[tuple[str, str], ...] = (("", text),)
    else:
        pairs = []
        for line_no, line in enumerate(text.split("\n"), 1):
            if not line:
                continue
            key, eq, value = line.partition("=")
            if not eq:
                raise GCodeParseError(
                    f"binary G-code {block.where()}: metadata line {line_no} ({line[:40]!r}) is not "
                    "key=value; the file is damaged, export it again"
                )
            pairs.append((key, value))
        items = tuple(pairs)
    return MetadataBlock(block.type, items, encoding, block.compression)


def _decode_thumbnail(block: RawBlock) -> Thumbnail:
    fmt, width, height = _THUMB.unpack(block.params)
    if fmt not in ThumbnailFormat._value2member_map_:
        raise UnsupportedFlavorError(
            f"binary G-code {block.where()}: unknown thumbnail format {fmt} (known: 0 PNG, 1 JPG, 2 QOI); "
            "update loadpath " + DISABLE_HINT
        )
    return Thumbnail(ThumbnailFormat(fmt), width, height, decompress(block), block.compression)


def _decode_gcode(block: RawBlock) -> tuple[bytes, GCodeBlockInfo]:
    encoding = _u16(block, "G-code encoding", GCodeEncoding)
    raw = decompress(block)
    text = raw if encoding == GCodeEncoding.NONE else meatpack.unpack(raw)
    return text, GCodeBlockInfo(block.compression, encoding, len(text))


# ---------------------------------------------------------------------------------------- encode


def encode(bg: BinaryGCode, gcode_text: str | bytes | None = None) -> bytes:
    """Write a binary G-code file: ``bg``'s header, metadata and thumbnails, and a G-code text.

    Parameters
    ----------
    bg : BinaryGCode
        From :func:`decode` (or :func:`new_container`); its checksum type, each metadata block's
        encoding and compression, the thumbnails and ``gcode_compression``/``gcode_encoding`` are
        kept as they are.
    gcode_text : str or bytes, optional
        The G-code to store (default: ``bg.gcode``). Split into blocks of whole lines of at most
        ``bg.block_size`` bytes, as PrusaSlicer does.

    Returns
    -------
    bytes
        The file.
    """
    text = bg.gcode if gcode_text is None else gcode_text
    raw = text.encode(*_TEXT) if isinstance(text, str) else bytes(text)
    parts = [write_file_header(bg.checksum, bg.version)]
    # metadata and thumbnails in the specification's order, keeping their order within a kind
    blocks = [(m.kind, m.compression, m.params(), m.payload()) for m in bg.metadata]
    blocks += [(BlockType.THUMBNAIL, t.compression, t.params(), t.data) for t in bg.thumbnails]
    blocks.sort(key=lambda b: _RANK[b[0]])  # stable
    parts.extend(write_block(*b, bg.checksum) for b in blocks)
    params = _U16.pack(int(bg.gcode_encoding))
    for chunk in _split_blocks(raw, bg.block_size):
        if bg.gcode_encoding == GCodeEncoding.NONE:
            payload = chunk
        else:
            payload = meatpack.pack(chunk, bg.gcode_encoding == GCodeEncoding.MEATPACK_COMMENTS)
        parts.append(write_block(BlockType.GCODE, bg.gcode_compression, params, payload, bg.checksum))
    return b"".join(parts)


def _split_blocks(raw: bytes, limit: int) -> Iterable[bytes]:
    """Cut text into chunks of whole lines, each at most ``limit`` bytes (a longer line is alone)."""
    if not raw:
        return
    ends = np.flatnonzero(np.frombuffer(raw, dtype=np.uint8) == 10) + 1
    if len(ends) == 0 or ends[-1] != len(raw):
        ends = np.append(ends, len(raw))
    start = 0
    while start < len(raw):
        j = int(np.searchsorted(ends, start + limit, side="right")) - 1
        if j < 0 or ends[j] <= start:  # one line longer than the limit: a block of its own
            j = int(np.searchsorted(ends, start, side="right"))
        stop = int(ends[j])
        yield raw[start:stop]
        start = stop


def new_container(
    printer: Mapping[str, str],
    print_: Mapping[str, str],
    slicer: Mapping[str, str],
    file: Mapping[str, str] | None = None,
    thumbnails: Iterable[Thumbnail] = (),
) -> BinaryGCode:
    """Make a container with PrusaSlicer's parameters (:data:`PRUSASLICER_PARAMS`) and this metadata."""
    p = PRUSASLICER_PARAMS
    enc = p["metadata_encoding"]
    blocks = []
    given = ((BlockType.FILE_METADATA, file), (BlockType.PRINTER_METADATA, printer),
             (BlockType.PRINT_METADATA, print_), (BlockType.SLICER_METADATA, slicer))
    for kind, items in given:
        if items is not None:
            pairs = tuple((str(k), str(v)) for k, v in items.items())
            blocks.append(MetadataBlock(kind, pairs, enc, p[kind]))
    return BinaryGCode(VERSION, p["checksum"], tuple(blocks), tuple(thumbnails),
                       gcode_compression=p[BlockType.GCODE], gcode_encoding=p["gcode_encoding"])


# ----------------------------------------------------------------------------------------- ASCII

_THUMB_TAG = {ThumbnailFormat.PNG: "thumbnail", ThumbnailFormat.JPG: "thumbnail_JPG",
              ThumbnailFormat.QOI: "thumbnail_QOI"}


def to_ascii(bg: BinaryGCode) -> str:
    """Render the ASCII G-code file PrusaSlicer's converter (``bgcode``) makes of this binary file.

    Layout: ``; generated by`` line from the file metadata, printer metadata as ``; key = value``,
    thumbnails as base64 comment blocks (78 characters a line), the G-code without blank lines,
    the print metadata, then the configuration between ``; prusaslicer_config = begin/end``.
    """
    out: list[str] = []
    file_meta = bg.metadata_of(BlockType.FILE_METADATA)
    if any(m.kind == BlockType.FILE_METADATA for m in bg.metadata):
        producer = file_meta.get("Producer", "Unknown")
        if "Produced on" in file_meta:
            producer += " on " + file_meta["Produced on"]
        if "Prepared by" in file_meta:
            producer += "\n; prepared by " + file_meta["Prepared by"]
        out.append(f"; generated by {producer}\n\n\n")
    out.extend(f"; {k} = {v}\n" for k, v in _items(bg, BlockType.PRINTER_METADATA))
    for t in bg.thumbnails:
        tag = _THUMB_TAG[t.format]
        b64 = base64.b64encode(t.data).decode("ascii")
        out.append(f"\n;\n; {tag} begin {t.width}x{t.height} {len(b64)}\n")
        out.extend(f"; {b64[i:i + 78]}\n" for i in range(0, len(b64), 78))
        out.append(f"; {tag} end\n;\n")
    out.append("\n")
    out.extend(line + "\n" for line in bg.gcode.split("\n") if _has_content(line))
    out.append("\n")
    out.extend(f"; {k} = {v}\n" for k, v in _items(bg, BlockType.PRINT_METADATA))
    for m in bg.metadata:
        if m.kind == BlockType.SLICER_METADATA and m.encoding == MetadataEncoding.JSON:
            out.append("\n; prusaslicer_json_config = begin\n")
            out.append(f"; {m.items[0][1]}\n; prusaslicer_json_config = end\n")
    config = _items(bg, BlockType.SLICER_METADATA)
    if config:
        out.append("\n; prusaslicer_config = begin\n")
        out.extend(f"; {k} = {v}\n" for k, v in config)
        out.append("; prusaslicer_config = end\n\n")
    return "".join(out)


def _items(bg: BinaryGCode, kind: BlockType) -> list[tuple[str, str]]:
    blocks = [m for m in bg.metadata if m.kind == kind and m.encoding == MetadataEncoding.INI]
    return [kv for m in blocks for kv in m.items]


def _has_content(line: str) -> bool:
    """Tell whether a line is more than blanks or a bare ``;`` (the converter drops those)."""
    line = line.strip(" \t")
    if line.startswith(";"):
        line = line[1:].strip(" \t")
    return bool(line)
