r"""Binary G-code (``.bgcode``, PrusaSlicer 2.7+), the container the reader decodes and the writer re-encodes.

:func:`decode`, :func:`encode` and :class:`BinaryGCode` are :mod:`.container`'s, whose docstring
says what a file holds, what a round trip keeps and how a reader and writer use it;
:mod:`.blocks` frames and checks the blocks, :mod:`.meatpack` and :mod:`.heatshrink` (the one
adapter of ``heatshrink2``) are the encodings.  The text reader reaches this package through one
hook, :func:`loadpath.gcode.decode_container`; nothing here imports the reader.
"""

from __future__ import annotations

from loadpath.gcode.bgcode import container
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

__all__ = list(container.__all__)  # the package's face is the container's
