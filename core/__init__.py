"""loadpath: stress-aligned infill for PrusaSlicer and Cura G-code.

The library (import name ``loadpath``) reads the G-code a slicer made, derives each layer's infill
regions from the perimeters, solves the user's load case with its own finite-element analysis,
replaces the chosen infill with paths that follow the principal stress, and writes the G-code back
with everything else untouched.

Units everywhere: mm, s, N, MPa (mm/min only where G-code feedrates are read or written).
"""

from loadpath.errors import (
    GCodeParseError,
    GeometryError,
    LoadCaseError,
    LoadpathError,
    LoadpathWarning,
    MeshingError,
    SettingsError,
    SolverError,
    ToolMissingError,
    UnsupportedFlavorError,
)

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "LoadpathError",
    "GCodeParseError",
    "UnsupportedFlavorError",
    "LoadCaseError",
    "GeometryError",
    "MeshingError",
    "SolverError",
    "SettingsError",
    "ToolMissingError",
    "LoadpathWarning",
]
