"""Structural checks of a parsed file: is it a slicer's complete, layered output.

Run by :func:`loadpath.gcode.parse` unless ``strict=False``.  Each failure is one line naming what is
wrong, where, and the fix.

What "truncated" means here: the file stops before the slicer's own closing line, i.e. one of

- a block opened and never closed (``; prusaslicer_config = begin`` without ``= end``,
  ``; CONFIG_BLOCK_START`` / ``; EXECUTABLE_BLOCK_START`` / ``; thumbnail begin`` without their end);
- PrusaSlicer 2.4 or newer without its closing ``; prusaslicer_config = end`` (always the last line);
  OrcaSlicer without ``; CONFIG_BLOCK_END``; Cura (CuraEngine) without ``;End of Gcode``;
- the last line has no line ending and is a command (cut in the middle of a line); slicers end every
  line, their last one included.

Old PrusaSlicer (< 2.4) wrote its config without delimiters and is only checked by the last rule.
"""

from __future__ import annotations

import re

from loadpath.errors import GCodeParseError, UnsupportedFlavorError
from loadpath.gcode.markers import Markers
from loadpath.gcode.model import Program
from loadpath.gcode.words import NO_COMMAND

__all__ = ["check_structure"]

_PAIRS = {
    "config": "'; <slicer>_config = end'",
    "config_block": "'; CONFIG_BLOCK_END'",
    "executable": "'; EXECUTABLE_BLOCK_END'",
    "header_block": "'; HEADER_BLOCK_END'",
}


def _version_at_least(version: str, major: int, minor: int) -> bool:
    m = re.match(r"(\d+)\.(\d+)", version)
    return bool(m) and (int(m.group(1)), int(m.group(2))) >= (major, minor)


def check_structure(program: Program, mk: Markers) -> None:
    """Raise if the file has no layer markers (unknown dialect) or looks truncated."""
    n = program.n_lines
    if not program.layers:
        raise UnsupportedFlavorError(
            f"no layer markers (';LAYER_CHANGE', '; CHANGE_LAYER' or ';LAYER:<n>') in the {n} lines of this "
            f"file (header: {program.dialect.name or 'none'}): loadpath reads the G-code of PrusaSlicer, "
            "SuperSlicer, "
            "OrcaSlicer, Bambu Studio and Cura with its comments; pass the slicer's own output, not a file "
            "whose comments were stripped"
        )
    why = _truncation(program, mk)
    if why:
        raise GCodeParseError(
            f"the file ends without {why}: it looks truncated (an interrupted export, upload or copy); "
            "export the G-code from the slicer again",
            line_no=n,
            text=program.line(n - 1) if n else None,
        )
    mv = program.moves
    extr = mv["extrude"] & (mv["layer"] >= 0)
    if extr.any() and not (mv["feature"][extr] >= 0).any():
        raise UnsupportedFlavorError(
            f"no feature markers (';TYPE:' or '; FEATURE:') before any of the {int(extr.sum())} extrusions "
            "in this file's layers: loadpath tells perimeters from infill by them; pass the slicer's own "
            "output, not a file whose comments were stripped")


def _truncation(program: Program, mk: Markers) -> str | None:
    pairs = mk.pairs
    for name, closing in _PAIRS.items():
        opened, closed = pairs.get("open:" + name, []), pairs.get("close:" + name, [])
        if opened and (not closed or closed[-1] < opened[-1]):
            return f"the closing {closing} line"
    opened, closed = pairs.get("open:thumbnail", []), pairs.get("close:thumbnail", [])
    if opened and (not closed or closed[-1] < opened[-1]):
        return "the '; thumbnail end' line of its last thumbnail"
    d = program.dialect
    if d.slicer == "PrusaSlicer" and _version_at_least(d.version, 2, 4) and not pairs.get("close:config"):
        return "PrusaSlicer's closing '; prusaslicer_config = end' line"
    if d.slicer == "OrcaSlicer" and not pairs.get("close:config_block"):
        return "OrcaSlicer's closing '; CONFIG_BLOCK_END' line"
    if d.slicer == "Cura" and not pairs.get("cura_end"):
        return "Cura's closing ';End of Gcode' line"
    n = program.n_lines
    if n and not program.data.endswith(b"\n") and program.state.cmd[n - 1] != NO_COMMAND:
        return "a line ending after its last command"
    return None
