"""The one exception tree of loadpath.

Every error a user can meet is a :class:`LoadpathError`. Its message is one line that names what is
wrong, where, and how to fix it; front ends print ``loadpath: <message>`` on stderr and exit non-zero.
Third-party failures (gmsh, OSQP, file I/O) are wrapped at the boundary into one of these classes.

::

    LoadpathError
    ├── GCodeParseError        (line_no, text, reason)
    ├── UnsupportedFlavorError (dialect or format we cannot process: binary G-code, G20, ...)
    ├── LoadCaseError          (bad TOML, selector that selects nothing, rigid-body motion, ...)
    ├── GeometryError          (no perimeters, regions that cannot be derived)
    ├── MeshingError           (wraps gmsh)
    ├── SolverError            (wraps OSQP status, FEA residual)
    ├── SettingsError          (bad option values)
    ├── ToolMissingError       (an external program is not installed)
    ├── SpliceError            (the spliced G-code failed its check; nothing was written)
    ├── BudgetError            (a stage's input exceeds its size budget: loadpath.budget)
    └── InternalError          (a bug or out of memory met by a job, worded as one line)
    LoadpathWarning
"""

from __future__ import annotations

import os

__all__ = [
    "LoadpathError",
    "GCodeParseError",
    "UnsupportedFlavorError",
    "LoadCaseError",
    "GeometryError",
    "MeshingError",
    "SolverError",
    "SettingsError",
    "ToolMissingError",
    "SpliceError",
    "BudgetError",
    "InternalError",
    "LoadpathWarning",
    "showing_tracebacks",
]


class LoadpathError(Exception):
    """Base class of every error loadpath raises on purpose.

    The message must be a single line: what is wrong, where, and how to fix it.
    """

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split("\n")))


class GCodeParseError(LoadpathError):
    """The G-code text cannot be read.

    Parameters
    ----------
    reason : str
        What is wrong and how to fix it.
    line_no : int or None
        1-based line number in the file, when the problem is at one line.
    text : str or None
        The offending line (shortened in the message).
    """

    def __init__(self, reason: str, line_no: int | None = None, text: str | None = None) -> None:
        self.reason = reason
        self.line_no = line_no
        self.text = text
        where = ""
        if line_no is not None:
            where = f"line {line_no}"
            if text is not None:
                shown = text if len(text) <= 60 else text[:57] + "..."
                where += f" ({shown.strip()!r})"
            where += ": "
        super().__init__(where + reason)


class UnsupportedFlavorError(LoadpathError):
    """The file is valid but of a kind loadpath cannot process (binary G-code, inch units, ...)."""


class LoadCaseError(LoadpathError):
    """The load case is invalid.

    Bad TOML, unknown keys, non-physical values, empty selectors, or supports that leave a body
    free to move.
    """


class GeometryError(LoadpathError):
    """Layer regions cannot be derived from the G-code (no perimeters, inconsistent loops, ...)."""


class MeshingError(LoadpathError):
    """gmsh failed to mesh a region; wraps the gmsh message."""


class SolverError(LoadpathError):
    """A numerical solve failed: QP status not solved, FEA residual too large, singular system."""


class SettingsError(LoadpathError):
    """An option (command line, load case ``[toolpath]``, slicer configuration) has a bad value."""


class ToolMissingError(LoadpathError):
    """An external program loadpath needs is not installed."""


class SpliceError(LoadpathError):
    """The spliced G-code failed the check that runs before writing.

    A bug to report; the input is left untouched.
    """


class BudgetError(LoadpathError):
    """A stage's input exceeds its size budget (:mod:`loadpath.budget`): stopped before the work.

    ``where`` names the layer or body once known; :meth:`at` adds it when the raiser did not know it.
    """

    def __init__(self, message: str, where: str = "") -> None:
        super().__init__(message)
        self.where = where

    def at(self, where: str) -> BudgetError:
        """The same error, prefixed with ``where`` (unless it already names a place)."""
        if self.where:
            return self
        return BudgetError(f"{where}: {self}", where)


class InternalError(LoadpathError):
    """A job met a bug (an unexpected exception) or ran out of memory.

    The message is still one line saying what became of the files; a service answers it as its own
    failure (HTTP 500), not as a problem with the request.
    """


class LoadpathWarning(UserWarning):
    """Base class of loadpath's warnings (things passed through, estimates that went stale, ...)."""


def showing_tracebacks() -> bool:
    """Whether a bug keeps its traceback instead of becoming one line: ``LOADPATH_DEBUG`` set to
    anything but empty or ``0`` (interface.md; the CLI's catch-all and a job's both ask here)."""
    return os.environ.get("LOADPATH_DEBUG", "") not in ("", "0")
