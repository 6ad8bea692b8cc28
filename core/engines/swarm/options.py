"""The swarm engine's options beyond the swarm's tuning (:class:`~.step.SwarmParams`): one frozen record.

:func:`~.engine.generate` takes them as keyword options; :meth:`SwarmOptions.from_options` reads
them (with the conversions and checks) and hands back what is left for :class:`~.step.SwarmParams`.
The engine registry (:mod:`loadpath.engines.registry`) names this class as the swarm's options.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from loadpath.errors import SettingsError

__all__ = ["SwarmOptions", "WIDTHS"]

WIDTHS = ("geometric", "swarm", "measured")


@dataclass(frozen=True)
class SwarmOptions:
    """How the swarm covers a region and finishes the layer (see :func:`~.engine.generate`).

    Attributes
    ----------
    coverage_target : float
        Stop starting swarms above this nominal-bead coverage.
    max_swarms : int
    fill : bool
        Start further swarms on uncovered pieces.
    fill_min_width : float, pitches
        The narrowest uncovered piece that gets a fill swarm.
    widths : {"measured", "geometric", "swarm"}
        Where the bead widths come from.
    width_cap : float, pitches
        The widest bead.
    extend_ends : bool
        Path ends carried on to the next bead or the edge.
    end_cap : float
    centre : float, pitches
        How far measured points move toward the wider of their two gaps (0: off).
    end_overlap : float or None
        How much of its own width an extension may cover of the beads beside it (None: only the
        centre-line clearance is checked).
    gaps : bool
        A straight bead in each void left where path ends meet.
    phase : float, pitches
        The seeds of every swarm move on by this much (0.5: the staggered copy).
    settle : float or None
        Pull back ends whose round end lies on another bead (None: off).
    join : bool
        Ends facing each other across a gap of up to two pitches become one path.
    hairpin : float or None
        Also join side-by-side ends by a hairpin keeping this many pitches from other paths.
    """

    coverage_target: float = 0.995
    max_swarms: int = 400
    fill: bool = True
    fill_min_width: float = 0.6
    widths: str = "measured"
    width_cap: float = 1.5
    extend_ends: bool = True
    end_cap: float = 0.0
    centre: float = 0.25
    gaps: bool = True
    phase: float = 0.0
    settle: float | None = None
    join: bool = True
    hairpin: float | None = None
    end_overlap: float | None = 0.0

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> tuple[SwarmOptions, dict[str, Any]]:
        """Read the fields from keyword options; return them and the options left over.

        Numbers and flags are converted as given (``int``, ``float``, ``bool``); ``settle``,
        ``hairpin`` and ``end_overlap`` may be None.  An unknown ``widths`` is a one-line
        :class:`~loadpath.errors.SettingsError`.
        """
        opts = dict(options)
        d = cls()
        kw: dict[str, Any] = {}
        for f in fields(cls):
            if f.name not in opts:
                continue
            v = opts.pop(f.name)
            default = getattr(d, f.name)
            if f.name in ("settle", "hairpin", "end_overlap"):
                kw[f.name] = None if v is None else float(v)
            else:
                kw[f.name] = type(default)(v)
        o = cls(**kw)
        if o.widths not in WIDTHS:
            raise SettingsError(
                f"widths = {o.widths!r}; use 'geometric' (from the finished layer)"
                " or 'swarm' (from the chains)"
            )
        return o, opts

    @classmethod
    def names(cls) -> set[str]:
        """Return the option names."""
        return {f.name for f in fields(cls)}
