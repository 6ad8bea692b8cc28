"""Streamline engine after Murugan's thesis (Ch. 4, App. C), faithful or fast.

``generate(inp, mode="default" | "faithful", **options) -> Toolpaths`` is the engine contract of
:mod:`loadpath.engines`; see :mod:`loadpath.engines.streamlines.engine` for the stages and
:mod:`loadpath.engines.streamlines.params` for the parameters of each mode.
"""

from loadpath.engines.streamlines.engine import generate
from loadpath.engines.streamlines.params import MODES, StreamlineParams, resolve_params

__all__ = ["generate", "MODES", "StreamlineParams", "resolve_params"]
