"""Bounds before work: every move of a file lies on the printer's bed, every number is a printable one.

Run by :func:`loadpath.gcode.parse` (``strict=True``) after the structural checks, before any stage
whose cost grows with the size of the part (layer geometry, meshing, the engines).  One mistyped
coordinate (``X106.717`` -> ``X1067.17``, ``Y76.728`` -> ``Y76728``) otherwise turns one layer into a
part metres wide, and the geometry's Voronoi split and the meshes grow with it.

Limits (:class:`Bounds`):

- X/Y: the bed from the file's own configuration (PrusaSlicer's ``bed_shape``, OrcaSlicer's / Bambu
  Studio's ``printable_area``) widened by :data:`MARGIN_MM` on every side (purge lines, wipers and
  park positions lie off the bed); without one, ``|x|, |y| <=`` :data:`GENEROUS_MM`.
- Z: ``-MARGIN_Z_MM`` to ``max_print_height`` / ``printable_height`` + :data:`MARGIN_MM`, else
  :data:`GENEROUS_MM`.
- ``;WIDTH:`` / ``;HEIGHT:`` (and Bambu's ``; LINE_WIDTH:``) of extrusions in layers: above 0 and at
  most :data:`MAX_BEAD_MM`.
- Feedrate: at most :data:`MAX_FEED_MM_MIN`.
- Filament per line: ``|dE| <=`` :data:`MAX_DE_MM`; along an extrusion in a layer at most
  :data:`MAX_DE_PER_MM` mm of filament per mm of path (a 10 mm x 5 mm bead of 1.75 mm filament), and
  over more than :data:`MIN_LEN_STARVED_MM` at least :data:`MIN_FLOW_SHARE` of what its
  ``;WIDTH:`` x ``;HEIGHT:`` bead needs (a file without ``;WIDTH:``, CuraEngine's: the median flow
  width of the move's feature); a perimeter at least :data:`MIN_WALL_FLOW_SHARE`.  Extrusions that
  climb (a spiral vase's, whose first turn ramps the flow up from nothing) are not held to these.
- Every value finite (overflowing numbers are refused when the words are read, :mod:`.words`).

Each failure is one :class:`~loadpath.errors.GCodeParseError` naming the line, the value, the limit
and where the limit comes from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from loadpath.errors import GCodeParseError
from loadpath.gcode.flavors import Role
from loadpath.gcode.model import Program, climbing
from loadpath.gcode.words import G, M

__all__ = ["Bounds", "bounds_of", "check_bounds", "MARGIN_MM", "GENEROUS_MM"]

MARGIN_MM = 100.0
"""Room beyond the configured bed for moves off it (purge lines, wipers, park positions), mm."""
MARGIN_Z_MM = 5.0
"""Room below the bed (negative Z offsets), mm."""
GENEROUS_MM = 1000.0
"""Limit on |X|, |Y|, Z when the file does not say how big its printer is, mm."""
MAX_BEAD_MM = 20.0
"""Largest ``;WIDTH:`` / ``;HEIGHT:`` accepted, mm."""
MAX_FEED_MM_MIN = 1.0e6
"""Largest feedrate accepted, mm/min (16.7 m/s)."""
MAX_DE_MM = 5000.0
"""Largest filament length one line may push or pull, mm."""
MAX_DE_PER_MM = 25.0
"""Largest filament per path length of an extrusion in a layer, mm/mm."""
MIN_FLOW_SHARE = 0.01
"""Least filament an extrusion longer than :data:`MIN_LEN_STARVED_MM` may carry, as a share of what
its ``;WIDTH:`` x ``;HEIGHT:`` bead needs (ironing, the thinnest real extrusion, runs at 10-15 %)."""
MIN_WALL_FLOW_SHARE = 0.25
"""The floor for perimeters (walls) instead: a wall vertex moved across the bed stretches its two
extrusions several times over (a corner of a small part moved 100-130 mm: 2-18 % of the bead) into
a spike or wedge one layer thick that the 3D FEA solves for minutes.  Real walls over 5 mm carry at
least 85 % (107 real slices: the committed files, the test suite's and the benchmarks' PrusaSlicer
and CuraEngine slices); CuraEngine's bridge walls 50 % (its default ``bridge_wall_material_flow``,
the lowest seen), PrusaSlicer's overhang perimeters their own bridge bead."""
MIN_LEN_STARVED_MM = 5.0
"""Shorter extrusions are not checked for :data:`MIN_FLOW_SHARE` (rounding of E on short moves)."""
_WALLS = np.array([Role.PERIMETER, Role.EXTERNAL_PERIMETER, Role.OVERHANG_PERIMETER])
_MIN_LEN_FOR_RATIO = 0.1  # mm: shorter moves carry rounding of their 3-decimal coordinates


@dataclass(frozen=True)
class Bounds:
    """The box every move must stay in, mm, and where it comes from (for the message)."""

    x: tuple[float, float]
    y: tuple[float, float]
    z: tuple[float, float]
    source: str
    z_source: str


def _shape_box(text: str) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """``"0x0,250x0,250x210,0x210"`` -> ((0, 250), (0, 210)); None if unreadable."""
    try:
        pts = [tuple(float(v) for v in p.strip().split("x")) for p in text.split(",") if p.strip()]
    except ValueError:
        return None
    if len(pts) < 3 or any(len(p) != 2 for p in pts):
        return None
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    if not all(np.isfinite(xs + ys)):
        return None
    return (min(xs), max(xs)), (min(ys), max(ys))


def _number(text: str | None) -> float | None:
    try:
        v = float(str(text).split(",")[0])
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) and v > 0 else None


def bounds_of(config: dict[str, str]) -> Bounds:
    """The box of :func:`check_bounds` from a file's embedded configuration."""
    g = GENEROUS_MM
    key = next((k for k in ("bed_shape", "printable_area") if k in config), None)
    box = _shape_box(config[key]) if key else None
    hkey = next((k for k in ("max_print_height", "printable_height") if k in config), None)
    height = _number(config.get(hkey)) if hkey else None
    if box is None:
        x, y, src = (-g, g), (-g, g), f"no bed size in the file: |X|, |Y| <= {g:g} mm"
    else:
        m = MARGIN_MM
        (x0, x1), (y0, y1) = box
        x, y = (x0 - m, x1 + m), (y0 - m, y1 + m)
        src = f"the bed {x0:g}..{x1:g} x {y0:g}..{y1:g} mm of the file's {key}, with {m:g} mm to spare"
    z = (-MARGIN_Z_MM, height + MARGIN_MM if height else g)
    zsrc = (f"the file's {hkey} {height:g} mm, with {MARGIN_MM:g} mm to spare" if height
            else f"no build height in the file: Z <= {g:g} mm")
    return Bounds(x=x, y=y, z=z, source=src, z_source=zsrc)


def _filament_area(config) -> float:
    """Cross-section of the file's filament, mm^2 (1.75 mm when the file does not say)."""
    d = _number(str(config.get("filament_diameter", "")).split(",")[0]) or 1.75
    return float(np.pi * d * d / 4.0) if 0.5 < d < 5.0 else float(np.pi * 1.75**2 / 4.0)


def _bead_widths(mv: np.ndarray, seg: np.ndarray, in_layer: np.ndarray,
                 area: float) -> tuple[np.ndarray, str]:
    """Bead width of every move: its ``;WIDTH:``, else the median flow width of its feature.

    A file without width markers (CuraEngine) has no nominal bead per move; the extrusions of one
    feature (outer wall, inner wall, skin, ...) share one line width, and their median flow width
    (``e * area / (length * height)``) is that feature's bead (0.400 mm on CuraEngine 4.13's small
    slices).  Per feature, not per file: Cura's infill lines may be set several times as wide as its
    walls.  The filament diameter cancels out of the share of :func:`check_bounds` in that case, so a
    wrong default (2.85 mm filament read as 1.75) does not matter.

    Parameters
    ----------
    mv : (n,) structured array (MOVE_DTYPE)
        The file's moves.
    seg : (n,) float, mm
        Their lengths in x-y.
    in_layer : (n,) bool
        Extrusions in a layer.
    area : float, mm^2
        Filament cross-section.

    Returns
    -------
    widths : (n,) float, mm
        Bead width of every move (NaN for a feature with no measurable extrusion).
    words : str
        What the message adds after a median bead's size (empty when every move has a width).
    """
    w = mv["width"]
    missing = ~(np.isfinite(w) & (w > 0))
    if not (missing & in_layer).any():  # PrusaSlicer & co.: travels have none, extrusions all have one
        return w, ""
    ok = in_layer & (seg >= _MIN_LEN_FOR_RATIO) & (mv["height"] > 0) & (mv["e"] > 0)
    fw = np.full(len(mv), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        fw[ok] = mv["e"][ok] * area / (seg[ok] * mv["height"][ok])
    ok &= np.isfinite(fw)
    typical = np.full(len(mv), np.nan)
    role = mv["role"]
    for r in np.unique(role[ok]):
        same = role == r
        typical[same] = np.median(fw[ok & same])
    return np.where(missing, typical, w), ": no ;WIDTH: for it, the median flow width of its feature"


def _fail(program: Program, line: int, what: str) -> None:
    st = program.state
    if not bool(st.absolute_xyz[line]):  # the likely cause: a G91 the file never switches back
        g91 = np.flatnonzero(st.cmd[: line + 1] == G + 91)
        at = f" at line {int(g91[-1]) + 1}" if len(g91) else ""
        what = what.split("; a mistyped number?")[0] + (
            f"; the line is in relative mode (G91{at}: X/Y/Z are steps from the last point, and slicers "
            "extrude in absolute mode): remove the G91 or switch back with G90 after it")
    raise GCodeParseError(what, line_no=line + 1, text=program.line(line))


def _check_e_mode(program: Program) -> None:
    """Absolute E (M82) with relative E numbers: most extrusions in the layers would run backwards."""
    mv = program.moves
    st = program.state
    xy = (mv["layer"] >= 0) & (np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"]) > 0) & (mv["e"] != 0)
    absolute = ~st.e_relative[mv["line"]]
    sel = xy & absolute
    n = int(sel.sum())
    if n < 20:
        return
    back = int((mv["e"][sel] < 0).sum())
    if back > 0.4 * n:
        i = int(mv["line"][np.flatnonzero(sel & (mv["e"] < 0))[0]])
        m82 = np.flatnonzero(st.cmd[: i + 1] == M + 82)
        at = f" (M82 at line {int(m82[-1]) + 1})" if len(m82) else ""
        raise GCodeParseError(
            f"the file is in absolute E mode{at} but its E values look relative: {back} of {n} moves in "
            "its layers would pull filament back; remove the M82 (or add M83) to match how the slicer "
            "wrote E, or export again", line_no=i + 1, text=program.line(i))


def check_bounds(program: Program) -> None:
    """Raise :class:`GCodeParseError` at the first line whose numbers the printer cannot print.

    Cost: a few vectorized passes over the moves (no Python loop over lines).
    """
    mv = program.moves
    if len(mv) == 0:
        return
    b = bounds_of(program.config)
    _check_e_mode(program)
    fix = "a mistyped number? export the G-code from the slicer again, or correct the line"
    checks = []  # (bad mask over moves, message builder)
    in_layer = mv["extrude"] & (mv["layer"] >= 0)
    relative = in_layer & ~program.state.absolute_xyz[mv["line"]]
    checks.append((relative, lambda i: "an extrusion in a layer"))
    for axis, (lo, hi) in (("x", b.x), ("y", b.y), ("z", b.z)):
        v = mv[axis + "1"]
        bad = ~np.isfinite(v) | (v < lo) | (v > hi)
        src = b.z_source if axis == "z" else b.source
        checks.append((bad, lambda i, a=axis, lo=lo, hi=hi, src=src: (
            f"{a.upper()} = {mv[a + '1'][i]:g} mm is off the printer ({lo:g} to {hi:g} mm: {src}); {fix}"
        )))
    f = mv["f"]
    checks.append(((f > MAX_FEED_MM_MIN) | np.isinf(f), lambda i: (
        f"feedrate F{f[i]:g} mm/min is beyond any printer (at most {MAX_FEED_MM_MIN:g}); {fix}")))
    e = mv["e"]
    checks.append((~np.isfinite(e) | (np.abs(e) > MAX_DE_MM), lambda i: (
        f"the line moves {e[i]:g} mm of filament at once (at most {MAX_DE_MM:g}); {fix}")))
    seg = np.hypot(mv["x1"] - mv["x0"], mv["y1"] - mv["y0"])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(seg >= _MIN_LEN_FOR_RATIO, e / np.maximum(seg, 1e-300), 0.0)
    checks.append((in_layer & (ratio > MAX_DE_PER_MM), lambda i: (
        f"the extrusion pushes {ratio[i]:.3g} mm of filament per mm of path (at most {MAX_DE_PER_MM:g}); {fix}")))
    # a long extrusion with almost no filament for its bead is a damaged coordinate (a perimeter point
    # moved across the bed turns one bead into a spike the FEA meshes into slivers)
    area = _filament_area(program.config)
    w, typical = _bead_widths(mv, seg, in_layer, area)
    h = mv["height"]
    with np.errstate(divide="ignore", invalid="ignore"):
        share = e * area / (seg * w * h)
    wall = np.isin(mv["role"], _WALLS)
    floor = np.where(wall, MIN_WALL_FLOW_SHARE, MIN_FLOW_SHARE)
    # a spiral vase climbs while its first turn ramps the flow up from nothing (PrusaSlicer's
    # spiral_vase: 9.7 % of the bead 100 mm into the turn): climbing extrusions are not damaged walls
    starved = in_layer & ~climbing(mv) & (seg > MIN_LEN_STARVED_MM) & (w > 0) & (h > 0) & (share < floor)
    checks.append((starved, lambda i: (
        f"the extrusion runs {seg[i]:.1f} mm with {e[i]:g} mm of filament, {100 * share[i]:.2g} % of what "
        f"its bead ({w[i]:.3g} x {h[i]:.3g} mm{'' if np.isfinite(mv['width'][i]) else typical}) needs (at "
        f"least {100 * floor[i]:g} %{' on a wall' if wall[i] else ''} over more than "
        f"{MIN_LEN_STARVED_MM:g} mm); {fix}")))
    for name, col in (("width", "width"), ("height", "height")):
        v = mv[col]
        low = (v <= 0) if (col == "width" or program.dialect.family != "cura") else np.zeros(len(v), bool)
        bad = in_layer & (low | (v > MAX_BEAD_MM) | np.isinf(v))  # Cura's heights are Z steps: <= 0 in
        # one-at-a-time prints
        checks.append((bad, lambda i, name=name, col=col: (
            f"the extrusion's {name} is {mv[col][i]:g} mm (the ;{name.upper()}: marker before it): "
            f"beads are above 0 and at most {MAX_BEAD_MM:g} mm; {fix}")))
    first = [(int(np.argmax(bad)), msg) for bad, msg in checks if bad.any()]
    if first:
        i, msg = min(first, key=lambda t: int(mv["line"][t[0]]))
        _fail(program, int(mv["line"][i]), msg(i))
