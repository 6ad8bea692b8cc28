"""Binary G-code (``.bgcode``, PrusaSlicer 2.7+), the container the reader decodes and the writer re-encodes.

>>> from loadpath.gcode import bgcode
>>> bgcode.decode(bgcode.encode(bgcode.new_container({}, {}, {}), "G1 X1\\n")).gcode
'G1 X1\\n'

Modules:

- :mod:`.container` -- :func:`decode` / :func:`encode`: header, metadata, thumbnails and G-code
  blocks of a file as a :class:`BinaryGCode`;
- :mod:`.blocks` -- the block layer: framing, checksums, compression (knows nothing of meaning);
- :mod:`.meatpack` -- the MeatPack G-code encoding;
- :mod:`.heatshrink` -- the one adapter of the ``heatshrink2`` library (LZSS compression).

The text reader (:mod:`loadpath.gcode`) reaches this package through one hook,
:func:`loadpath.gcode.decode_container`; nothing here imports the reader.
"""

from __future__ import annotations

from loadpath.gcode.bgcode.container import (
    GCODE_BLOCK_SIZE,
    PRUSASLICER_PARAMS,
    BinaryGCode,
    BlockType,
    ChecksumType,
    Compression,
    GCodeBlockInfo,
    GCodeEncoding,
    MetadataBlock,
    MetadataEncoding,
    Thumbnail,
    ThumbnailFormat,
    decode,
    encode,
    is_bgcode,
    new_container,
    to_ascii,
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
