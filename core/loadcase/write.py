"""Write a load case as TOML (interface.md, version 1), laid out like the interface doc's example.

:func:`to_toml` is the inverse of :func:`loadpath.loadcase.parse`: ``parse(to_toml(lc))`` gives a
load case equal to ``lc`` (same selectors, supports, loads, material and options).  Each support and
load can carry a comment saying what its selector picked on the part (:func:`describe_pick`), so a
reader of the file sees which hole or edge a coordinate means.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping

import numpy as np
from loadpath.loadcase.model import (
    AXES,
    BoxSelector,
    HoleSelector,
    Load,
    LoadCase,
    Selector,
    SideSelector,
    Support,
    ToolpathOptions,
)
from loadpath.loadcase.select import Selection

__all__ = ["to_toml", "selector_toml", "describe_pick"]


def _num(v: float) -> str:
    """Write a TOML float that reads back to the same value (``1000.0``, ``0.35``, ``-2.5e-05``)."""
    if not math.isfinite(v):
        raise ValueError(f"cannot write {v!r} into a load case; give a finite number")
    return repr(float(v))


def _str(s: str) -> str:
    return json.dumps(s, ensure_ascii=False)  # a JSON string is a valid TOML basic string


def selector_toml(sel: Selector) -> str:
    """Return the inline table of a selector: ``{ side = "x_min", within = 10.0 }``."""
    if isinstance(sel, SideSelector):
        body = f"side = {_str(sel.side)}, within = {_num(sel.within)}"
    elif isinstance(sel, HoleSelector):
        body = f"hole_near = [{_num(sel.near[0])}, {_num(sel.near[1])}], radius = {_num(sel.radius)}"
    elif isinstance(sel, BoxSelector):
        parts = []
        for i, a in enumerate(AXES):
            if sel.lower[i] > -math.inf:
                parts.append(f"{a}_min = {_num(sel.lower[i])}")
            if sel.upper[i] < math.inf:
                parts.append(f"{a}_max = {_num(sel.upper[i])}")
        body = ", ".join(parts)
    else:  # pragma: no cover
        raise TypeError(f"not a selector: {sel!r}")
    return "{ " + body + " }"


def describe_pick(sel: Selection, analysis: str) -> str:
    """One line on what a selection picked, for the comment above its entry.

    Parameters
    ----------
    sel : Selection
    analysis : {"2d", "3d"}

    Returns
    -------
    str
        E.g. ``picks the hole at x 147.50, y 92.50 (5.00 mm across), z 0.00..3.00`` or
        ``picks 15.00 mm of outline in x 95.00..110.00, y 124.00..125.00, z 0.00..3.00 (45.00 mm²)``;
        ``picks nothing`` when empty.
    """
    area = sel.measure(analysis)
    if area <= 0:
        return "picks nothing"
    if sel.holes:
        ring = sel.holes[0][2]
        c = np.asarray(ring.coords)[:-1, :2]
        mid = c.mean(axis=0)
        across = 2.0 * float(np.mean(np.linalg.norm(c - mid, axis=1)))
        z0, z1 = sel.holes[0][0], sel.holes[-1][1]
        return (
            f"picks the hole at x {mid[0]:.2f}, y {mid[1]:.2f} ({across:.2f} mm across), z {z0:.2f}..{z1:.2f}"
        )
    lines = sel.lines
    out = []
    if lines is not None and not lines.is_empty:
        x0, y0, x1, y1 = lines.bounds
        z0 = min(z for z, _, _ in sel.lateral)
        z1 = max(z for _, z, _ in sel.lateral)
        out.append(
            f"{lines.length:.2f} mm of outline in x {x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f}, "
            f"z {z0:.2f}..{z1:.2f}"
        )
    if analysis == "3d" and sel.faces:
        out.append(f"{sel.area_faces:.2f} mm² of top/bottom faces")
    return "picks " + " and ".join(out) + f" ({area:.2f} mm²)"


def _support(s: Support, note: str | None) -> list[str]:
    out = ["[[supports]]"]
    if note:
        out.append(f"# {note}")
    out += [
        f"name = {_str(s.name)}",
        f"where = {selector_toml(s.where)}",
        "fix = [" + ", ".join(_str(a) for a in s.fix) + "]",
    ]
    return out


def _load(ld: Load, note: str | None) -> list[str]:
    out = ["[[loads]]"]
    if note:
        out.append(f"# {note}")
    out += [f"name = {_str(ld.name)}", f"where = {selector_toml(ld.where)}"]
    if ld.force is not None:
        kind = "bearing load on the hole" if ld.is_bearing else "uniform traction"
        out.append("force = [" + ", ".join(_num(v) for v in ld.force) + f"]  # N, total force ({kind})")
    else:
        out.append(f"pressure = {_num(ld.pressure or 0.0)}  # MPa, normal to the boundary (positive pushes)")
    return out


def _toolpath(t: ToolpathOptions) -> list[str]:
    rows = []
    if t.engine is not None:
        rows.append(f"engine = {_str(t.engine)}")
    if t.sparse_engine is not None:
        rows.append(f"sparse_engine = {_str(t.sparse_engine)}")
    if t.pitch is not None:
        rows.append(f"pitch = {_num(t.pitch)}  # mm")
    if t.K is not None:
        rows.append(f"K = {_num(t.K)}")
    if t.principal is not None:
        rows.append(f"principal = {_str(t.principal)}")
    if t.replace is not None:
        rows.append("replace = [" + ", ".join(_str(k) for k in t.replace) + "]")
    if t.density is not None:
        rows.append(f"density = {_str(t.density)}")
    if t.sparse_fill is not None:
        rows.append(f"sparse_fill = {_num(t.sparse_fill)}  # mean fill of the replaced sparse infill, 0-1")
    if not rows:
        return []
    return ["[toolpath]              # command-line options win over this section", *rows]


def to_toml(lc: LoadCase, picks: Mapping[str, str] | None = None, header: str | None = None) -> str:
    """Return the TOML text of a load case.

    Parameters
    ----------
    lc : LoadCase
    picks : mapping, optional
        Support / load name -> comment on what its selector picked (:func:`describe_pick`).
    header : str, optional
        A comment line at the top (e.g. which part the case was made on).

    Returns
    -------
    str
        Ends with a newline; :func:`loadpath.loadcase.parse` reads it back to ``lc``.
    """
    picks = picks or {}
    out = []
    if header:
        out += [f"# {line}" for line in header.splitlines()]
    out.append("version = 1")
    if lc.object is not None:
        out.append(f"object = {_str(lc.object)}")
    frame_note = (
        "coordinates relative to the part's minimum corner"
        if lc.frame == "part"
        else "coordinates of the G-code (the printer bed)"
    )
    out.append(f"frame = {_str(lc.frame)}  # {frame_note}")
    out += [
        "",
        "[material]              # isotropic linear elastic, used for the stress analysis",
        f"youngs_modulus = {_num(lc.material.youngs_modulus)}  # MPa",
        f"poissons_ratio = {_num(lc.material.poissons_ratio)}",
    ]
    for s in lc.supports:
        out += ["", *_support(s, picks.get(s.name))]
    for ld in lc.loads:
        out += ["", *_load(ld, picks.get(ld.name))]
    tp = _toolpath(lc.toolpath)
    if tp:
        out += ["", *tp]
    return "\n".join(out) + "\n"
