"""A run's verdict: what was replaced and what it gained, in one line every front end shows.

:func:`build` makes a :class:`Verdict` from a pipeline result; :meth:`Verdict.line` is the text the
command line prints on stderr, the G-code carries as a ``; loadpath: ...`` header comment, the log
file, the Cura plugin's message, the service's answer and the batch table show.  Everything here is
arithmetic on what the run already has (splice reports, the print-time estimate of the file), except
the predicted stiffness and failure-load change (:func:`loadpath.stiffness.change.predicted_change`:
the model of ``loadpath compare`` on the slicer's file and the output, two solves per body, first-ply
failure on the same solves; the same figures ``compare`` prints), which a caller may leave out.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from typing import Any

from loadpath import __version__

__all__ = [
    "Verdict",
    "build",
    "HEADER_PREFIX",
    "header_line",
    "find_header",
    "without_header",
    "total_print_seconds",
    "signed",
    "percent",
]

HEADER_PREFIX = "; loadpath: "
"""How the verdict starts in the G-code header (and how a processed file is recognised)."""

# the date as build() writes it (its minute has a colon of its own), else up to the first colon
_HEADER_RE = re.compile(r"^; loadpath: loadpath (\S+) on (\d{4}-\d\d-\d\dT\d\d:\d\dZ|\S+?):")
_HEADER_LINE_RE = re.compile(rb"(?m)^" + re.escape(HEADER_PREFIX.encode()) + rb"[^\n]*\n")


@dataclass(frozen=True)
class Verdict:
    """What a run did and gained.

    Attributes
    ----------
    version : str
        loadpath's version.
    date : str
        UTC time of the run, ISO 8601 (``2026-12-01T22:10Z``).
    changed : bool
        Some infill was replaced.
    layers : tuple of int
        1-based layers with replaced blocks.
    kinds : tuple of str
        Infill kinds replaced, loadpath's words whatever the slicer (``"solid"``, ``"sparse"``, ...).
    engine : str
    stiffness : float or None
        Predicted stiffness change, absolute (``+0.08``: 8 % stiffer): ``loadpath compare``'s
        ``relative_stiffness - 1`` of the output against the slicer's file; None: not predicted.
    stiffness_same_mass : float or None
        The same per gram of material.
    failure_load : float or None
        Predicted failure-load change, absolute: ``compare``'s ``relative_failure_load - 1`` (None: not
        predicted).
    failure_load_same_mass : float or None
        The same per gram of material.
    model : str
        What the prediction covers (``"stiffness only"``, or the failure model and material).
    time_change_s : float
        Print-time change (the splicer's kinematic estimate), s.
    time_change_pct : float or None
        Against the slicer's own estimate of the whole print (None when the file has none).
    mass_change_g : float
    warnings : int
    note : str
        Why nothing was replaced, or what the prediction could not do.
    density : str
        With ``density = "auto"``: the sparse density criterion kept and the predictions that chose
        it (:mod:`loadpath.plugin.density_choice`); empty otherwise.
    solid : str
        Where the level sets gave way on solid infill (no engine named): the layout kept and the
        predictions that chose it (:mod:`loadpath.plugin.solid_choice`); empty otherwise.
    printability : dict or None
        Paths, retractions and travel of the replaced blocks and the moves into them, the slicer's
        and the output's (:func:`loadpath.printability.verdict_counts`); None: not counted.
    printability_note : str
        Why they were not counted (a file over the budget).
    """

    version: str
    date: str
    changed: bool
    layers: tuple[int, ...] = ()
    kinds: tuple[str, ...] = ()
    engine: str = ""
    stiffness: float | None = None
    stiffness_same_mass: float | None = None
    failure_load: float | None = None
    failure_load_same_mass: float | None = None
    model: str = "stiffness only"
    time_change_s: float = 0.0
    time_change_pct: float | None = None
    mass_change_g: float = 0.0
    warnings: int = 0
    note: str = ""
    extra: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    density: str = ""
    solid: str = ""
    printability: dict | None = None
    printability_note: str = ""

    def line(self) -> str:
        """The one-line summary (no newline)."""
        head = f"loadpath {self.version} on {self.date}: "
        w = f"{self.warnings} warning{'s' * (self.warnings != 1)}"
        if not self.changed:
            return head + f"nothing replaced ({self.note or 'no infill to replace'}); the G-code is the slicer's; {w}"
        parts = [f"replaced {', '.join(self.kinds)} infill on {_layers(self.layers)} with {self.engine}"]
        if self.density:
            parts.append(f"sparse density {self.density}")
        if self.solid:
            parts.append(f"solid infill: {self.solid}")
        if self.stiffness is not None and math.isfinite(self.stiffness):
            text = (
                f"predicted stiffness {percent(self.stiffness)} absolute, {percent(self.stiffness_same_mass)} at the "
                f"same mass"
            )
            if self.failure_load is not None:
                text += (
                    f", failure load {percent(self.failure_load)} absolute, {percent(self.failure_load_same_mass)} at the "
                    f"same mass ({self.model})"
                )
            else:
                text += f" ({self.model})"
            parts.append(text)
        else:
            parts.append(f"stiffness not predicted ({self.note or 'no model result'})")
        pct = f" ({signed(self.time_change_pct)} %)" if self.time_change_pct is not None else ""
        parts.append(f"print time {signed(self.time_change_s / 60)} min{pct}")
        parts.append(_counts(self.printability, self.printability_note))
        parts.append(f"mass {signed(self.mass_change_g, 2)} g")
        parts.append(w)
        return head + "; ".join(parts)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready fields plus ``line``."""
        d = asdict(self)
        d.pop("extra")
        d["layers"], d["kinds"] = list(self.layers), list(self.kinds)
        d["line"] = self.line()
        return d


def _counts(p: dict | None, note: str) -> str:
    """``infill paths 25 -> 563, retractions 25 -> 488, travel 327 -> 1732 mm`` (slicer -> output)."""
    if not p:
        return f"retractions and travel not counted ({note or 'not asked for'})"
    s, n = p["slicer"], p["loadpath"]
    return (
        f"infill paths {s['paths']:d} -> {n['paths']:d}, retractions {s['retractions']:d} -> "
        f"{n['retractions']:d}, travel {s['travel_mm']:.0f} -> {n['travel_mm']:.0f} mm"
    )


def signed(v: float, digits: int = 1) -> str:
    """``v`` to ``digits`` decimals with its sign, a change that rounds to nothing as ``+0.0`` (not
    ``-0.0``).

    Examples
    --------
    >>> signed(-0.04), signed(-0.06), signed(2.345), signed(-0.004, 2)
    ('+0.0', '-0.1', '+2.3', '+0.00')
    """
    r = round(v, digits)
    return f"{r + 0.0:+.{digits}f}" if r != 0 else f"+{0.0:.{digits}f}"


def percent(v: float | None, unknown: str = "?") -> str:
    """A relative change ``v`` in per cent, one decimal, signed as :func:`signed`; ``unknown`` when
    there is none (the verdict line and the report's table).

    Examples
    --------
    >>> percent(-0.0004), percent(0.0123), percent(None)
    ('+0.0 %', '+1.2 %', '?')
    """
    return unknown if v is None or not math.isfinite(v) else f"{signed(100 * v)} %"


def _layers(layers: tuple[int, ...]) -> str:
    """How many layers, and which, as runs of consecutive ones (at most four runs named).

    "3 layers (2-39)" told a user of a 40-layer gusset that the whole height was replaced where
    three layers were (2, 3 and 39).

    Examples
    --------
    >>> _layers((2, 3, 4)), _layers((2, 21, 39)), _layers((5,))
    ('3 layers (2-4)', '3 layers (2, 21, 39)', '1 layer (5)')
    >>> _layers((1, 2, 5, 8, 9, 12, 15, 16))
    '8 layers (1-2, 5, 8-9, ..., 15-16)'
    """
    if not layers:
        return "no layers"
    n = len(layers)
    ordered = sorted(set(layers))
    runs: list[list[int]] = []
    for k in ordered:
        if runs and k == runs[-1][1] + 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    named = [f"{a}" if a == b else f"{a}-{b}" for a, b in runs]
    if len(named) > 4:
        named = [*named[:3], "...", named[-1]]
    return f"{n} layer{'s' * (n != 1)} ({', '.join(named)})"


_TIME_RE = re.compile(rb"^; estimated printing time \(normal mode\) = (.+?)\s*$", re.M)
_CURA_TIME_RE = re.compile(rb"^;TIME:([0-9.]+)\s*$", re.M)


def total_print_seconds(data: bytes) -> float | None:
    """The slicer's own estimate of the whole print from a text file's first or last 64 kB, s."""
    from loadpath.splice.splicer import parse_duration

    for chunk in (data[-65536:], data[:65536]):
        m = _TIME_RE.search(chunk)
        if m:
            return parse_duration(m.group(1).decode("ascii", "replace"))
        m = _CURA_TIME_RE.search(chunk)
        if m:
            return float(m.group(1))
    return None


def build(
    result,
    engine: str,
    filament_diameter: float,
    warnings: int,
    density: float = 1.24,
    stiffness: Any = None,
    note: str = "",
    total_seconds: float | None = None,
) -> Verdict:
    """Make the verdict of a pipeline result.

    Parameters
    ----------
    result : loadpath.pipeline.PipelineResult or None
        None: the run failed and the slicer's G-code was kept (``note`` says why).
    engine : str
        The run's engine; where the replaced kinds were laid by different engines (the runs'
        :attr:`~loadpath.pipeline.EngineRun.engine`), the verdict names each with its kinds, sparse
        infill last: ``swarm (solid), levelset (sparse)``.
    filament_diameter : float, mm
    warnings : int
        How many warnings the run printed.
    density : float, g/cm³
        Of the filament (PLA's 1.24 by default).
    stiffness : StiffnessChange or None
        :func:`loadpath.stiffness.change.predicted_change`'s result.
    note : str
        Why nothing was replaced, or why the stiffness is missing.
    total_seconds : float, optional
        The slicer's estimate of the whole print, for the per-cent change.
    """
    date = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%MZ")
    if result is None or not result.changed:
        why = note or (result.passthrough if result is not None and result.passthrough else "")
        skipped = result.splice.skipped if result is not None and result.splice is not None else ()
        if not why and skipped:  # there was infill, and every block of it was refused
            n = len(skipped)
            which = "the infill block" if n == 1 else f"all {n} infill blocks"
            why = f"{which} to replace kept as sliced: {skipped[0][1]}"
        return Verdict(__version__, date, False, engine=engine, warnings=warnings, note=why)
    blocks = result.splice.blocks
    layers = tuple(sorted({b.layer + 1 for b in blocks}))
    kind_of = {b.block_index: u.kind for jr in result.jobs for u in jr.units for b in u.blocks}
    kinds = tuple(dict.fromkeys(kind_of.get(b.block, b.feature) for b in blocks))
    # engine -> the kinds it laid, sparse infill named last (solid infill may have two: the level
    # sets where they hold, the swarm where they give way)
    ran = dict.fromkeys((u.kind, jr.engine) for jr in result.jobs for u in jr.units if jr.engine)
    groups: dict[str, list[str]] = {}
    for k, e in sorted((p for p in ran if p[0] in kinds), key=lambda p: p[0] == "sparse"):
        groups.setdefault(e, []).append(k)
    if len(groups) > 1:
        engine = ", ".join(f"{e} ({', '.join(ks)})" for e, ks in groups.items())
    elif groups:
        engine = next(iter(groups))
    farea = math.pi * filament_diameter**2 / 4
    dmass = sum(b.filament_new - b.filament_old for b in blocks) * farea * density * 1e-3
    dt = float(result.splice.seconds_delta)
    pct = 100.0 * dt / total_seconds if total_seconds else None
    return Verdict(
        __version__,
        date,
        True,
        layers,
        kinds,
        engine,
        None if stiffness is None else float(stiffness.absolute),
        None if stiffness is None else float(stiffness.same_mass),
        None if stiffness is None else stiffness.failure_load,
        None if stiffness is None else stiffness.failure_load_same_mass,
        "stiffness only" if stiffness is None else stiffness.label,
        dt,
        pct,
        float(dmass),
        warnings,
        note,
        {"stiffness": stiffness},
    )


def header_line(verdict: Verdict) -> str:
    """The verdict as the G-code comment (no newline)."""
    return HEADER_PREFIX + verdict.line()


def find_header(data: bytes, limit: int = 65536) -> tuple[str, str] | None:
    """``(version, date)`` of loadpath's own header comment in a file's first ``limit`` bytes, or None."""
    head = data[:limit]
    i = head.find(HEADER_PREFIX.encode())
    if i < 0:
        return None
    line = head[i : head.find(b"\n", i) if b"\n" in head[i:] else len(head)].decode("utf-8", "replace")
    m = _HEADER_RE.match(line)
    return (m.group(1), m.group(2)) if m else ("?", "an unknown date")


def without_header(data: bytes) -> bytes:
    """The G-code ``data`` without loadpath's verdict line (``; loadpath: ...``, line ending included).

    The line carries the minute of the run: two runs of the same job give the same file but for it,
    so outputs are compared through this.
    """
    return _HEADER_LINE_RE.sub(b"", data)
