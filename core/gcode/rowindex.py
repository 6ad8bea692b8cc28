"""Fast move-row lookups for code that asks many times (the splicer, its check, the report).

``Program.move_rows`` searches ``moves["line"]``, a strided field view that numpy copies on every
search; for thousands of lookups on a large file that copy dominates.  :func:`move_rows` keeps one
contiguous copy per program (weakly cached) and searches that.
"""

from __future__ import annotations

import weakref

import numpy as np
from loadpath.gcode.model import Program

__all__ = ["move_rows", "move_lines"]

_LINES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def move_lines(program: Program) -> np.ndarray:
    """``program.moves["line"]`` as one contiguous int64 array (cached per program)."""
    lines = _LINES.get(program)
    if lines is None:
        lines = np.ascontiguousarray(program.moves["line"], dtype=np.int64)
        _LINES[program] = lines
    return lines


def move_rows(program: Program, start: int, stop: int) -> slice:
    """Rows of ``program.moves`` produced by lines ``[start, stop)`` (as ``Program.move_rows``)."""
    lines = move_lines(program)
    return slice(int(np.searchsorted(lines, start, "left")), int(np.searchsorted(lines, stop, "left")))
