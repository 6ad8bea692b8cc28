r"""The beads as printed: fusion with neighbours, load transfer near bead ends, crossings between plies.

What a ply of beads carries depends on more than its fill.  This module measures, from the beads
alone (any slicer pattern: no table of patterns), the three things the bead fill model
(:func:`bead_ply_matrices`) needs.

Fusion with neighbours (thesis §3.2, the NMO idea, made geometric; the neighbour search:
:func:`_neighbours`)
    A bead is a stadium of height ``h`` and width ``w_s = w + h (1 - pi/4)``, where ``w`` is its
    flow width (volume / (length h), the slicer's bead pitch at 100 %; PrusaSlicer's flow model).
    Two parallel neighbours whose centre lines are ``d`` apart overlap by
    ``delta = (w_s,a + w_s,b) / 2 - d``; their rounded flanks then share a neck of height
    ``b = h sqrt(1 - (1 - delta/h)^2)`` (``b = h`` once ``delta >= h``, none for ``delta <= 0``).
    A coupon's across-bead stiffness and strength were measured at the slicer's solid spacing
    (``d = w``: ``delta = h (1 - pi/4)``, ``b/h = 0.619``), so the fused fraction of a bead is
    ``phi = min(1, b / b_ref)``, the smaller of its two sides (load across a bead passes both necks
    in series); a side with nothing within reach is unfused, except on a wall bead, whose empty
    side is the part's free surface.
Load transfer near bead ends (shear lag, Cox 1952)
    A bead picks up its load over a transfer length from its ends; at distance ``x`` from the end of
    a run of length ``l`` it carries ``eta(x) = 1 - cosh(beta (l/2 - x)) / cosh(beta l / 2)`` of
    what an endless bead would.  Runs are chains of consecutive extrusions turning by less than
    35 degrees (a zig-zag's U-turn ends the run: load does not turn a hairpin).  The shear-lag
    constant couples the bead to its fused neighbours through the bond and to the plies above and
    below through the crossings: ``beta^2 = 2 G12 phi / (E1 w^2) + 2 G12 w / (E1 h^2 s)`` with ``s``
    its distance to the nearest neighbour (the crossing pitch of a stack of equal plies).  With PLA
    numbers the transfer length ``1/beta`` is about one bead width, so only the beads' last
    millimetre at a hole or a wall is affected, as it should be.
Crossings (what holds a sparse stack together)
    Plies are bonded where their beads cross; between crossings an unfused bead is a beam.  A shear
    of the ply bends these beams (a grid with rigid joints, Gibson & Ashby's square honeycomb:
    ``G = E/2 (t/l)^3`` for one layer holding both bar families), which gives an unfused ply of
    bead fraction ``v`` the shear stiffness ``v G_b`` with ``G_b = E1/4 (w / L_c)^2``, ``L_c`` the
    distance between crossings along the bead (:func:`crossing_spacing`, from the line densities
    and angles of the neighbouring plies).  A pin-jointed ±45 sparse stack under tension is a
    mechanism; these bending joints are all that stiffens it besides the walls.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from loadpath._typing import Floats, Points2
from loadpath.gcode.flavors import Role
from loadpath.stiffness.deposits import Deposits

__all__ = [
    "BeadState",
    "subdivide",
    "bead_state",
    "neck_fraction",
    "crossing_spacing",
    "bead_ply_matrices",
    "UNFUSED_E2",
]

PIECE = 1.0
"""mm: longest piece a bead is cut into, so that fusion and transfer are resolved along it (about the
stiffness mesh's finest elements, two pitches; 2 mm pieces miss a sliver gap beside a hole)."""

_PARALLEL = np.cos(np.radians(25.0))
_CANDIDATES = 8  # nearest bead pieces looked at per piece (both sides, both neighbours' pieces)
_CONE = np.tan(np.radians(60.0))  # a neighbour lies within 60 degrees of the bead's normal
_TURN = np.cos(np.radians(35.0))
_NECK_REF = float(np.sqrt(1.0 - (np.pi / 4.0) ** 2))  # b/h at the slicer's solid spacing
_WALLS = np.array([int(Role.PERIMETER), int(Role.EXTERNAL_PERIMETER), int(Role.OVERHANG_PERIMETER)])
UNFUSED_E2 = 1e-3
"""Across-bead stiffness left to an unfused bead, as a fraction of E2 (not zero: not singular); the
layout bound's envelope takes the same (:func:`loadpath.stiffness.optimum.envelope`)."""


@dataclass(frozen=True)
class BeadState:
    """Per-bead state of a set of deposits (after :func:`subdivide`).

    Attributes
    ----------
    fused : (n,) float in [0, 1]
        Fused fraction (module docstring).
    transfer : (n,) float in [0, 1]
        Mean shear-lag efficiency along the bead piece.
    spacing : (n,) float, mm
        Distance to the nearest parallel neighbour (inf: none within reach).
    """

    fused: Floats
    transfer: Floats
    spacing: Floats


def subdivide(dep: Deposits, piece: float = PIECE) -> Deposits:
    """Cut every bead into pieces no longer than ``piece`` mm (volume shared by length)."""
    n_cut = np.maximum(1, np.ceil(dep.length / piece)).astype(np.int64)
    if np.all(n_cut == 1):
        return dep
    row = np.repeat(np.arange(len(dep)), n_cut)
    k = np.arange(len(row)) - np.repeat(np.cumsum(n_cut) - n_cut, n_cut)
    t0 = (k / n_cut[row])[:, None]
    t1 = ((k + 1) / n_cut[row])[:, None]
    d = dep.end[row] - dep.start[row]
    return Deposits(
        dep.start[row] + t0 * d,
        dep.start[row] + t1 * d,
        dep.z0[row],
        dep.height[row],
        dep.volume[row] / n_cut[row],
        dep.layer[row],
        dep.role[row],
    )


def neck_fraction(d: np.ndarray, w_a: np.ndarray, w_b: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Fused fraction ``phi = min(1, b / b_ref)`` of two beads ``d`` mm apart (module docstring)."""
    stadium = 0.5 * (w_a + w_b) + h * (1.0 - np.pi / 4.0)
    delta = np.clip((stadium - d) / h, 0.0, 1.0)
    b = np.sqrt(np.maximum(0.0, 1.0 - (1.0 - delta) ** 2))
    return np.minimum(1.0, b / _NECK_REF)


def _neighbours(dep: Deposits) -> tuple[Floats, Floats, Floats, np.ndarray, np.ndarray]:
    """Per bead: fused fraction of its left and right sides, distance to the nearest neighbour, and
    whether anything lies on each side at all.

    The neighbour on a side is the nearest point of another bead's centre line seen from the bead's
    midpoint within 60 degrees of its normal: a parallel neighbour (its foot of perpendicular) or the
    end of a bead that butts against it (infill meeting a wall at an angle).

    (Layer by layer, :func:`_layer_neighbours`.  A layer depends on nothing but its own beads, so a
    layer whose beads are byte for byte those of a layer of this call or of the previous one (the
    slicer's file, then loadpath's with the same layers kept; a stack of equal layers) takes that
    layer's result: :data:`_LAYERS` (the last few); and, inside :func:`layer_store`, one kept by an
    earlier run or by this one.)
    """
    n = len(dep)
    left = np.zeros(n)
    right = np.zeros(n)
    near = np.full(n, np.inf)
    any_l = np.zeros(n, dtype=bool)
    any_r = np.zeros(n, dtype=bool)
    a, b = dep.start, dep.end
    mid = 0.5 * (a + b)
    d = b - a
    length = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-12)
    u = d / length[:, None]
    w = dep.flow_width
    h = dep.height
    order = np.argsort(dep.layer, kind="stable")
    bounds = np.flatnonzero(np.diff(dep.layer[order])) + 1
    store = _STORES[-1] if _STORES else None
    for rows in np.split(order, bounds):
        if len(rows) < 2:
            continue
        h_key = hashlib.sha256()
        for x in (a[rows], b[rows], w[rows], h[rows]):
            h_key.update(np.ascontiguousarray(x).tobytes())
        key = h_key.digest()
        got = _LAYERS.get(key) or (store.get(key) if store is not None else None)
        if got is None:
            got = _layer_neighbours(mid[rows], a[rows], u[rows], length[rows], w[rows], h[rows])
            if store is not None:
                store.put(key, got)
        _remember(key, got)
        left[rows], right[rows], near[rows], any_l[rows], any_r[rows] = got
    return left, right, near, any_l, any_r


_LAYERS: dict[bytes, tuple[np.ndarray, ...]] = {}
"""The last layers :func:`_neighbours` measured or read (key: SHA-256 of their beads), in this process
only, at most :data:`LAYERS_BYTES` of them (oldest out first)."""

LAYERS_BYTES = 64 << 20
"""What :data:`_LAYERS` may hold: 26 bytes a bead piece, the last 180 layers of a 150 x 36 mm solid
specimen (the whole part's, 350 MB at 1000 layers, made the memory grow with the layers)."""

_HELD = [0]


def _remember(key: bytes, got: tuple[np.ndarray, ...]) -> None:
    """Keep ``got`` in :data:`_LAYERS` (as the newest), dropping the oldest beyond :data:`LAYERS_BYTES`."""
    if key in _LAYERS:
        _LAYERS[key] = _LAYERS.pop(key)
        return
    _LAYERS[key] = got
    _HELD[0] += sum(x.nbytes for x in got)
    while _HELD[0] > LAYERS_BYTES and len(_LAYERS) > 1:
        old = _LAYERS.pop(next(iter(_LAYERS)))
        _HELD[0] -= sum(x.nbytes for x in old)


_STORES: list = []


@contextmanager
def layer_store(store) -> Iterator[None]:  # type: ignore[no-untyped-def]
    """Inside the block, :func:`_neighbours` also reads and keeps layers in ``store``.

    ``store`` has ``get(key: bytes) -> tuple | None`` and ``put(key: bytes, value: tuple)``; the key
    names only the layer's beads, so the store must add the code (the verdict's run cache does:
    :func:`loadpath.stiffness.change.predicted_change`).  The block starts and ends with
    :data:`_LAYERS` empty.
    """
    _forget()
    _STORES.append(store)
    try:
        yield
    finally:
        _STORES.pop()
        _forget()


def _forget() -> None:
    """Empty :data:`_LAYERS` (a store's block starts and ends with none: its layers come from the store)."""
    _LAYERS.clear()
    _HELD[0] = 0


def _layer_neighbours(
    mid: np.ndarray, a: np.ndarray, u: np.ndarray, length: np.ndarray, w: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, ...]:
    """:func:`_neighbours` of the beads of one layer (midpoints, starts, directions, lengths, widths,
    heights): ``left, right, near, any_l, any_r``.

    On the layer's own contiguous coordinate columns; the candidate pairs come grouped by bead, so
    each side's maximum and the nearest distance are segment reductions, not ``ufunc.at``.
    """
    from scipy.spatial import cKDTree

    n = len(mid)
    left = np.zeros(n)
    right = np.zeros(n)
    near = np.full(n, np.inf)
    any_l = np.zeros(n, dtype=bool)
    any_r = np.zeros(n, dtype=bool)
    # far enough to see a neighbour whose stadium still touches (1.2 x the widest usual bead)
    touch = 1.2 * float(np.quantile(w, 0.99) + np.quantile(h, 0.99))
    reach = 0.5 * float(np.max(length)) + touch
    k = min(_CANDIDATES + 1, n)
    dd, nb = cKDTree(mid).query(mid, k=k, distance_upper_bound=reach, workers=-1)
    ok = np.isfinite(dd[:, 1:])
    i = np.repeat(np.arange(n), k - 1)[ok.ravel()]  # grouped by bead
    j = nb[:, 1:][ok]
    mx, my = mid[:, 0].copy(), mid[:, 1].copy()
    ux, uy = u[:, 0].copy(), u[:, 1].copy()
    ax, ay = a[:, 0].copy(), a[:, 1].copy()
    mxi, myi, uxi, uyi = mx[i], my[i], ux[i], uy[i]
    axj, ayj, uxj, uyj, lj = ax[j], ay[j], ux[j], uy[j], length[j]
    t = np.clip(((mxi - axj) * uxj + (myi - ayj) * uyj) / lj, 0.0, 1.0)
    s = t * lj
    rx = axj + s * uxj - mxi
    ry = ayj + s * uyj - myi
    along = rx * uxi + ry * uyi
    off = rx * -uyi + ry * uxi
    dist = np.hypot(along, off)
    keep = (np.abs(along) <= _CONE * np.abs(off)) & (dist > 1e-3) & (dist < touch)
    i, j, off, dist = i[keep], j[keep], off[keep], dist[keep]
    phi = neck_fraction(dist, w[i], w[j], h[i])
    lft = off > 0
    for side, any_side, sel in ((left, any_l, lft), (right, any_r, ~lft)):
        g, top = _group_reduce(i[sel], phi[sel], np.maximum)
        side[g] = np.maximum(side[g], top)
        any_side[g] = True
    g, low = _group_reduce(i, dist, np.minimum)
    near[g] = np.minimum(near[g], low)
    return left, right, near, any_l, any_r


def _group_reduce(idx: np.ndarray, val: np.ndarray, ufunc: np.ufunc) -> tuple[np.ndarray, np.ndarray]:
    """Distinct values of a grouped (equal values adjacent) index array and ``ufunc`` over each group."""
    if not len(idx):
        return idx, val
    first = np.flatnonzero(np.concatenate([[True], idx[1:] != idx[:-1]]))
    return idx[first], ufunc.reduceat(val, first)


def _runs(dep: Deposits) -> tuple[Floats, Floats, Floats]:
    """Per bead: position of its start and end along its run, and the run's length (mm)."""
    length, _, brk = run_breaks(dep.start, dep.end, dep.layer)
    return run_positions(length, brk, np.cumsum(length))


def run_breaks(start: Points2, end: Points2, layer: np.ndarray) -> tuple[Floats, Points2, np.ndarray]:
    """Lengths, unit directions and where a run starts (``(n,)`` bool, the first bead always) of beads
    in print order: a run goes on while the next bead starts where the last ended, in the same layer,
    turning by less than 35 degrees."""
    n = len(start)
    d = end - start
    length = np.hypot(d[:, 0], d[:, 1])
    u = d / np.maximum(length, 1e-12)[:, None]
    brk = np.ones(n, dtype=bool)
    if n > 1:
        joined = np.hypot(*(start[1:] - end[:-1]).T) < 1e-6
        straight = np.einsum("ij,ij->i", u[1:], u[:-1]) >= _TURN
        brk[1:] = ~(joined & straight & (layer[1:] == layer[:-1]))
    return length, u, brk


def run_positions(length: Floats, brk: np.ndarray, cum: Floats) -> tuple[Floats, Floats, Floats]:
    """:func:`_runs` from the lengths, the run starts and the running sum of the lengths ``cum``
    (``np.cumsum(length)``, or what it was in a longer sequence: the positions are its differences)."""
    run = np.cumsum(brk) - 1
    run_start = (cum - length)[brk]
    s0 = cum - length - run_start[run]
    s1 = s0 + length
    total = np.bincount(run, weights=length)[run]
    return s0, s1, total


def _mean_eta(s0: Floats, s1: Floats, total: Floats, beta: Floats) -> Floats:
    """Mean of ``1 - cosh(beta (l/2 - x)) / cosh(beta l/2)`` over ``x`` in ``[s0, s1]`` (overflow-safe)."""
    y = beta * total / 2.0

    def sinh_over_cosh(x: np.ndarray) -> np.ndarray:  # sinh(x) / cosh(y), |x| <= y
        return (np.exp(x - y) - np.exp(-x - y)) / (1.0 + np.exp(-2.0 * y))

    x0 = beta * (total / 2.0 - s0)
    x1 = beta * (total / 2.0 - s1)
    span = np.maximum(beta * (s1 - s0), 1e-12)
    return np.clip(1.0 - (sinh_over_cosh(x0) - sinh_over_cosh(x1)) / span, 0.0, 1.0)


def bead_state(dep: Deposits, E1: float, G12: float, runs: tuple | None = None) -> BeadState:  # noqa: N803
    """Fusion, transfer and spacing of every bead (module docstring).

    Parameters
    ----------
    dep : Deposits
        Beads in print order (consecutive rows form runs), ideally :func:`subdivide`\\ d.
    E1, G12 : float, MPa
        The card's along-bead modulus and shear modulus (the shear-lag constant).
    runs : (s0, s1, total), optional
        :func:`_runs` of ``dep`` when ``dep`` is part of a longer print (:mod:`.layered`).

    Returns
    -------
    BeadState
    """
    left, right, near, any_l, any_r = _neighbours(dep)
    fused = np.minimum(left, right)
    # a wall bead with nothing at all on one side lies on the part's surface: that side is free, not
    # unfused, and the bead is as fused as its other side
    wall = np.isin(dep.role, _WALLS)
    fused = np.where(wall & ~any_l, right, np.where(wall & ~any_r, left, fused))
    w = np.maximum(dep.flow_width, 1e-3)
    h = dep.height
    s = np.where(np.isfinite(near), np.maximum(near, w), 2.0 * PIECE)
    beta = np.sqrt(2.0 * G12 / E1 * (fused / w**2 + w / (h**2 * s)))
    s0, s1, total = _runs(dep) if runs is None else runs
    return BeadState(fused, _mean_eta(s0, s1, total, beta), near)


def crossing_spacing(density: np.ndarray, c2: np.ndarray, s2: np.ndarray, order: np.ndarray) -> np.ndarray:
    """Distance between crossings along the beads of every ply and element, ``(L, m)`` mm.

    Parameters
    ----------
    density : (L, m) float, 1/mm
        Bead length per area of each ply (``fill / flow width``).
    c2, s2 : (L, m) float
        Direction moments ``<cos 2t>, <sin 2t>`` of each ply.
    order : (L,) int
        Plies in stacking order (indices into the first axis); neighbours in it are bonded.
        The plies above and below count once, the larger of the two: in a repeated stack (0/90,
        +-45) the lines above and below a ply lie over each other, so their crossings coincide.

    Returns
    -------
    (L, m) float
        ``1 / n_c`` with ``n_c`` the crossings per unit length: from the plies just above and below,
        the larger ``density_j <|sin(t - t_j)|>`` (``<sin^2> = (1 - <cos 2t><cos 2t_j> - <sin 2t><sin 2t_j>)/2``),
        and within the ply from its own spread of directions, ``density (1 - R) / 2`` with ``R`` the
        length of ``(<cos 2t>, <sin 2t>)`` (two families at 90 degrees: half the beads cross the
        other half).
    """
    L = density.shape[0]
    own = density * (1.0 - np.hypot(c2, s2)) / 2.0
    across = np.zeros_like(density)
    pos = np.empty(L, dtype=np.int64)
    pos[np.asarray(order)] = np.arange(L)
    for k in range(L):
        for j in (pos[k] - 1, pos[k] + 1):
            if 0 <= j < L:
                q = order[j]
                sin2 = np.clip(0.5 * (1.0 - c2[k] * c2[q] - s2[k] * s2[q]), 0.0, 1.0)
                across[k] = np.maximum(across[k], density[q] * np.sqrt(sin2))
    return 1.0 / np.maximum(own + across, 1e-3)


def bead_ply_matrices(
    Q: np.ndarray,  # noqa: N803
    E1: float,  # noqa: N803
    fill: np.ndarray,
    fused: np.ndarray,
    transfer: np.ndarray,
    bending: np.ndarray,
) -> np.ndarray:
    """Local (bead-axes) stiffness of a ply of beads, ``(m, nv, nv)`` MPa.

    ``v [phi C_card + (1 - phi) C_unfused]`` with the along-bead terms scaled by the transfer
    efficiency; ``C_unfused`` keeps ``E1`` along the bead, a trace of ``E2`` across it and the
    bending shear ``G_b`` (module docstring).

    Parameters
    ----------
    Q : (nv, nv) float, MPa
        The card's full-density local matrix (plane stress 3x3 or 3D 6x6, bead axes).
    E1 : float, MPa
    fill, fused, transfer : (m,) float
        Effective fill ``v``, fused fraction ``phi``, transfer efficiency ``eta``.
    bending : (m,) float, MPa
        ``G_b`` per element (capped at the card's in-plane shear modulus).
    """
    nv = Q.shape[0]
    v = np.asarray(fill, dtype=float)[:, None, None]
    phi = np.clip(fused, 0.0, 1.0)[:, None, None]
    U = np.zeros((len(fill), nv, nv))
    if nv == 3:
        U[:, 0, 0] = E1
        U[:, 1, 1] = UNFUSED_E2 * Q[1, 1]
        U[:, 2, 2] = np.minimum(bending, Q[2, 2])
    else:
        U[:, 0, 0] = E1
        U[:, 1, 1] = U[:, 2, 2] = UNFUSED_E2 * Q[1, 1]
        U[:, 3, 3] = UNFUSED_E2 * Q[3, 3]
        U[:, 4, 4] = np.minimum(bending, Q[4, 4])  # 13: the bead bends about z between crossings
        U[:, 5, 5] = np.minimum(bending, Q[5, 5])  # 12
    C = v * (phi * Q[None] + (1.0 - phi) * U)
    eta = np.clip(transfer, 0.0, 1.0)
    C[:, 0, :] *= eta[:, None]
    C[:, :, 0] *= eta[:, None]
    C[:, 0, 0] /= np.maximum(eta, 1e-12)  # the (1,1) term took eta twice
    return C


def attributes(dep: Deposits, E1: float, G12: float) -> tuple[Deposits, dict[str, np.ndarray]]:  # noqa: N803
    """Subdivide the beads and measure their state: what :func:`~.fields.sample_deposits` averages.

    Returns
    -------
    deposits : Deposits
        :func:`subdivide`\\ d.
    attributes : dict
        ``fused`` and ``transfer`` per bead piece.
    """
    pieces = subdivide(dep)
    st = bead_state(pieces, E1, G12)
    return pieces, {"fused": st.fused, "transfer": st.transfer}


def ply_sum(fields, material, dim: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """``sum_k weight_k C_k`` over the bead model's plies, ``(m, nv, nv)`` MPa, one ply at a time.

    ``C_k`` is ply ``k``'s global (x, y) stiffness; the plies are added in order, as
    ``np.einsum("l,lmij->mij", ...)`` over their ``(L, m, nv, nv)`` stack would, without the
    stack (190 MB at 1000 layers).

    Parameters
    ----------
    fields : PlyFields
        Sampled with :func:`attributes`' arrays (``extra["fused"]``, ``extra["transfer"]``).
    material : PrintedMaterial
    dim : {2, 3}
    """
    out = None
    for w, C in zip(fields.weight, _plies(fields, material, dim)):
        out = w * C if out is None else out + w * C
    assert out is not None
    return out


def _plies(fields, material, dim: int) -> Iterator[np.ndarray]:  # type: ignore[no-untyped-def]
    from loadpath.fea.orthotropic import orientation_average

    fill = np.clip(fields.effective_fill(), 1e-3, None)
    width = np.maximum(fields.extra["width"], 1e-3)
    raw = np.minimum(fields.fill, 1.25)
    density = raw / width
    del raw
    mom = fields.moments
    order = np.argsort(fields.layers, kind="stable")
    Lc = crossing_spacing(density, mom[..., 0], mom[..., 1], order)  # noqa: N806
    del density
    Q = material.local(dim)  # noqa: N806
    for k in range(len(fields.layers)):
        gb = 0.25 * material.E1 * (width[k] / Lc[k]) ** 2
        fused = fields.extra.get("fused", np.ones_like(fill))[k]
        transfer = fields.extra.get("transfer", np.ones_like(fill))[k]
        loc = bead_ply_matrices(Q, material.E1, fill[k], fused, transfer, gb)
        yield orientation_average(loc, mom[k], dim)


def crossings(fields) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Crossing spacing ``(L, m)`` mm of a :class:`~.fields.PlyFields` (:func:`crossing_spacing`)."""
    width = np.maximum(fields.extra["width"], 1e-3)
    density = np.minimum(fields.fill, 1.25) / width
    order = np.argsort(fields.layers, kind="stable")
    return crossing_spacing(density, fields.moments[..., 0], fields.moments[..., 1], order)
