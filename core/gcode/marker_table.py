"""The frequent slicer markers, matched and read for all comment lines at once with numpy.

A layer carries a dozen markers (``;LAYER_CHANGE``, ``;Z:``, ``;HEIGHT:``, ``;TYPE:``, ``;WIDTH:``,
``;WIPE_START`` ...), about a tenth of a PrusaSlicer file's lines: too many for a Python pass at a
million lines per second.  Here each comment line's first bytes are compared with every known
prefix in one vectorized step, numbers after a prefix go through :func:`parse_numbers`, and feature
names are grouped with ``np.unique`` so only the distinct names are decoded.  Lines this table does
not settle (object labels, config blocks, headers, unusual spellings) go to the Python pass of
:mod:`loadpath.gcode.markers`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from loadpath._typing import Ints
from loadpath.gcode.numbers import parse_numbers

if TYPE_CHECKING:  # markers.py imports this module
    from loadpath.gcode.markers import Markers

__all__ = ["MarkerTable", "match_markers", "merge_into", "PREFIXES"]

PREFIXES: tuple[tuple[bytes, str, bool], ...] = (
    # (prefix, kind, whole line)
    (b";LAYER_CHANGE", "layer_prusa", True),
    (b"; CHANGE_LAYER", "layer_bambu", True),
    (b";Z:", "z", False),
    (b"; Z_HEIGHT:", "z", False),
    (b";HEIGHT:", "height", False),
    (b"; LAYER_HEIGHT:", "height", False),
    (b";WIDTH:", "width", False),
    (b"; LINE_WIDTH:", "width", False),
    (b";TYPE:", "feature", False),
    (b"; FEATURE:", "feature", False),
    (b";WIPE_START", "wipe_start", True),
    (b"; WIPE_START", "wipe_start", True),
    (b";WIPE_END", "wipe_end", True),
    (b"; WIPE_END", "wipe_end", True),
    (b";LAYER:", "layer_cura", False),
    (b";TIME_ELAPSED:", "time_elapsed", False),
    (b";BEFORE_LAYER_CHANGE", "barrier", False),
    (b";AFTER_LAYER_CHANGE", "barrier", False),
    (b"; printing object ", "object_start", False),
    (b"; stop printing object", "object_stop", False),
    (b";MESH:", "mesh", False),
)
"""Prefixes read here, with the kind of marker they start."""

_NUMERIC = ("z", "height", "width", "layer_cura")
_NAMED = {"feature": 48, "object_start": 128, "mesh": 128}  # kind -> longest name read here


@dataclass
class MarkerTable:
    """Lines (sorted, 0-based) and values of the markers matched here, per kind.

    ``lines[kind]`` for every kind of :data:`PREFIXES`; ``values[kind]`` for the numeric kinds;
    for the named kinds (features, object labels, Cura meshes) ``names[kind]`` the distinct names in
    order of first appearance and ``codes[kind]`` the index of each line's name in it; ``handled``
    the comment lines settled here.
    """

    lines: dict[str, Ints] = field(default_factory=dict)
    values: dict[str, np.ndarray] = field(default_factory=dict)
    names: dict[str, list[str]] = field(default_factory=dict)
    codes: dict[str, Ints] = field(default_factory=dict)
    handled: Ints = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


def match_markers(buf: np.ndarray, first: Ints, ends: Ints, lines: Ints) -> MarkerTable:
    """Match and read the :data:`PREFIXES` on ``lines`` (comment-only lines).

    Parameters
    ----------
    buf : (n_bytes + pad,) uint8
    first, ends : (n_lines,) int
        Offset of each line's first non-blank byte and of its content end.
    lines : (k,) int
        Candidate lines, sorted.
    """
    out = MarkerTable()
    k = len(lines)
    s, e = first[lines], ends[lines]
    clen = e - s
    kind_of = np.full(k, -1, dtype=np.int64)
    heads: dict[int, np.ndarray] = {}  # the first n bytes of every line as one V<n> item, per length n
    for code, (prefix, _kind, whole) in enumerate(PREFIXES):
        n = len(prefix)
        if n not in heads:
            heads[n] = np.ndarray(shape=(len(buf) - n,), dtype=f"V{n}", buffer=buf, strides=(1,))[s]
        m = (heads[n] == np.frombuffer(prefix, dtype=f"V{n}")[0]) & (clen >= n)
        if whole:
            after = buf[np.minimum(s + n, len(buf) - 1)]
            m &= (clen == n) | (after == 32) | (after == 9)
        kind_of[m & (kind_of < 0)] = code
    handled = kind_of >= 0
    plen_of = np.array([len(p) for p, _, _ in PREFIXES] + [0])[kind_of]
    kind_name = np.array([kind for _, kind, _ in PREFIXES] + [""])[kind_of]
    # numbers of all numeric markers in one call
    num_sel = np.flatnonzero(handled & np.isin(kind_name, _NUMERIC))
    start = s[num_sel] + plen_of[num_sel]
    for _ in range(2):  # '; Z_HEIGHT: 0.2' puts a blank after the colon
        start = start + ((buf[start] == 32) & (start < e[num_sel]))
    num_val, num_len = parse_numbers(buf, start, e[num_sel])
    handled[num_sel[num_len <= 0]] = False
    value_of = np.zeros(k)
    value_of[num_sel] = num_val
    for kind in sorted({kind for _, kind, _ in PREFIXES}):
        sel = np.flatnonzero(handled & (kind_name == kind))
        plen = plen_of[sel]
        if kind in _NUMERIC:
            out.values[kind] = value_of[sel]
        elif kind in _NAMED and len(sel):
            start = s[sel] + plen
            for _ in range(2):
                start = start + ((buf[start] == 32) & (start < e[sel]))
            room = e[sel] - start
            fits = room <= _NAMED[kind]
            handled[sel[~fits]] = False  # very long names: the Python pass reads them
            sel, start, room = sel[fits], start[fits], room[fits]
            out.names[kind], out.codes[kind] = _names(buf, start, room, _NAMED[kind])
        out.lines[kind] = lines[sel]
    out.handled = lines[handled]
    return out


def _names(buf: np.ndarray, start: Ints, room: Ints, width: int) -> tuple[list[str], Ints]:
    """Distinct names (decoded, stripped, in order of first appearance) and each line's index."""
    if len(start) == 0:
        return [], np.zeros(0, dtype=np.int64)
    if int(start.max()) + width > len(buf):  # a name on the file's last line (a cut file): pad the window
        buf = np.concatenate([buf, np.zeros(width, dtype=np.uint8)])
    items = np.ndarray(shape=(len(buf) - width + 1,), dtype=f"V{width}", buffer=buf, strides=(1,))
    win = items[start].view(np.uint8).reshape(len(start), width)
    win = np.where(np.arange(width) < room[:, None], win, np.uint8(0))
    raw = np.ascontiguousarray(win).view(f"S{width}").ravel()
    uniq, first_at, inverse = np.unique(raw, return_index=True, return_inverse=True)
    order = np.argsort(first_at)
    rank = np.zeros(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    names = [uniq[i].decode("utf-8", "replace").strip() for i in order]
    canon: dict[str, int] = {}  # two spellings that differ only in trailing blanks are one name
    remap = np.array([canon.setdefault(nm, len(canon)) for nm in names], dtype=np.int64)
    return list(canon), remap[rank[inverse.ravel()]]


def _sorted(lines_a, values_a, lines_b, values_b) -> tuple[np.ndarray, np.ndarray]:
    lines = np.concatenate([np.asarray(lines_a, dtype=np.int64), np.asarray(lines_b, dtype=np.int64)])
    values = np.concatenate([np.asarray(values_a), np.asarray(values_b)]) if values_a is not None else None
    order = np.argsort(lines, kind="stable")
    return lines[order], (values[order] if values is not None else None)


def merge_into(mk: Markers, t: MarkerTable) -> None:
    """Fold the vectorized table into the Python pass's lists (as sorted arrays)."""
    empty = np.zeros(0, dtype=np.int64)

    def lines(kind: str) -> np.ndarray:
        return t.lines.get(kind, empty)

    def values(kind: str) -> np.ndarray:
        return t.values.get(kind, np.zeros(0))

    mk.z_lines, mk.z_values = _sorted(lines("z"), values("z"), mk.z_lines, np.asarray(mk.z_values, float))
    mk.height_lines, mk.height_values = _sorted(
        lines("height"), values("height"), mk.height_lines, np.asarray(mk.height_values, float)
    )
    mk.width_lines, mk.width_values = _sorted(
        lines("width"), values("width"), mk.width_lines, np.asarray(mk.width_values, float)
    )
    mk.feature_lines, mk.feature_codes = _sorted(
        lines("feature"),
        t.codes.get("feature", empty),
        mk.feature_lines,
        np.asarray(mk.feature_codes, dtype=np.int64),
    )
    # object labels: '; printing object <label>' / '; stop printing object' / Cura ';MESH:<name>'
    ol, oc = [lines("object_stop")], [np.full(len(lines("object_stop")), -1, dtype=np.int64)]
    for kind in ("object_start", "mesh"):
        names = t.names.get(kind, [])
        codes = np.array(
            [-1 if (kind == "mesh" and nm == "NONMESH") else mk.object_code(nm) for nm in names],
            dtype=np.int64,
        )
        ol.append(lines(kind))
        oc.append(codes[t.codes[kind]] if len(names) else empty)
    mk.object_lines, mk.object_ids = _sorted(
        np.concatenate(ol), np.concatenate(oc), mk.object_lines, np.asarray(mk.object_ids, dtype=np.int64)
    )
    wl = np.concatenate([lines("wipe_start"), lines("wipe_end")])
    wv = np.concatenate([np.ones(len(lines("wipe_start")), bool), np.zeros(len(lines("wipe_end")), bool)])
    mk.wipe_lines, mk.wipe_values = _sorted(wl, wv, mk.wipe_lines, np.asarray(mk.wipe_values, dtype=bool))
    for fam in ("prusa", "bambu"):
        mk.layer_lines[fam] = np.union1d(
            lines("layer_" + fam), np.asarray(mk.layer_lines[fam], dtype=np.int64)
        )
    cura, numbers = _sorted(
        lines("layer_cura"),
        values("layer_cura").astype(np.int64),
        mk.layer_lines["cura"],
        np.asarray(mk.cura_layer_numbers, dtype=np.int64),
    )
    mk.layer_lines["cura"], mk.cura_layer_numbers = cura, numbers
    mk.time_elapsed_lines = np.union1d(
        lines("time_elapsed"), np.asarray(mk.time_elapsed_lines, dtype=np.int64)
    )
    custom = [i for i, name in enumerate(mk.features) if name == "Custom"]
    mk.custom_lines = np.union1d(
        mk.feature_lines[np.isin(mk.feature_codes, custom)], np.asarray(mk.custom_lines, dtype=np.int64)
    )
    barrier = [
        lines(k)
        for k in (
            "layer_prusa",
            "layer_bambu",
            "layer_cura",
            "z",
            "time_elapsed",
            "barrier",
            "object_start",
            "object_stop",
            "mesh",
        )
    ]
    mk.barrier_lines = np.unique(np.concatenate(barrier + [np.asarray(mk.barrier_lines, dtype=np.int64)]))
