r"""From beads to per-element material: fill and filament-direction moments per ply and element.

Each bead (a rectangle: centre line x flow width x layer height) is integrated over the mesh by
sampling: points every ``resolution`` mm along the bead and across its flow width (and, in 3D, at
two heights in its layer), each carrying an equal share of the bead's volume.  A point is given to
the element that contains it; points outside the mesh (outside the part outline) are dropped.  Per
element and ply:

* ``volume``: the material that landed in it, mm³;
* ``fill = volume / (element area * ply height)`` (2D) or ``volume / element volume`` (3D);
* ``moments``: volume-weighted means of ``cos 2t, sin 2t, cos 4t, sin 4t`` of the bead directions
  ``t`` (sign-free: a bead and its reverse give the same moments; the second moments are the
  direction tensor ``<n n>``, the fourth ``<n n n n>``; see :mod:`loadpath.fea.orthotropic`).

2D (plane stress): one ply per layer on the same triangles; the part is the stack of its plies.  3D:
one "ply" holding every tetrahedron (layers are resolved by the tetrahedra themselves).

The sampling error of an element's fill is about ``resolution * perimeter / area`` per bead that
crosses its edge; elements a few pitches wide and ``resolution`` a fifth of the pitch keep it to a
few per cent (tested against exact fills in ``tests/stiffness``).

Effective fill (what the stiffness uses, :meth:`PlyFields.effective_fill`)
    A layer cannot be denser than solid plastic, but an element's sampled fill can exceed 1 for two
    reasons: beads really overlap there (a slicer's infill-perimeter overlap, bunched paths), or a
    bead straddling the element's edge was split unevenly between it and its neighbour (sampling).
    Capping each element at 1 would turn the second, which averages out over neighbours, into a
    spurious loss of stiffness.  So the fill is divided by ``max(1, neighbourhood fill)``, the
    volume-weighted fill of the element and every element sharing a corner with it: excess material
    is spread over its neighbourhood (as squeezed-out plastic fills neighbouring voids), a truly
    over-filled neighbourhood is brought down to solid, and a lone over-filled element next to
    voids keeps its material.  The result is then capped at :data:`MAX_FILL`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from loadpath._typing import Floats, Ints
from loadpath.errors import GeometryError
from loadpath.fea.locate import TriangleLocator
from loadpath.mesh.data import MeshData
from loadpath.stiffness.deposits import Deposits

__all__ = ["PlyFields", "sample_deposits", "tet_section", "bead_grid", "DEFAULT_RESOLUTION", "MAX_FILL"]

DEFAULT_RESOLUTION = 0.1
"""mm between sample points along and across a bead (a quarter of a 0.4 mm nozzle's bead)."""

MAX_FILL = 1.25
"""Largest effective fill (a neighbourhood of voids can absorb only so much of a lone element's excess)."""

_CHUNK = 1 << 21  # sample points per batch
_Z_SAMPLES = 2  # heights per layer in 3D
_TET_EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]])


@dataclass(frozen=True)
class PlyFields:
    """Material per ply and element.

    Attributes
    ----------
    layers : (L,) int
        Layer index of each ply (2D), ``[-1]`` for the single ply of a 3D mesh.
    height : (L,) float, mm
        Ply (layer) height; 3D: NaN.
    weight : (L,) float
        Share of the plate thickness each ply takes (2D: ``height / thickness``); 3D: ``[1]``.
    fill : (L, m) float
        Material volume / element volume (not capped).
    moments : (L, m, 4) float
        Direction moments ``<cos 2t>, <sin 2t>, <cos 4t>, <sin 4t>`` (zeros where no bead).
    volume : (L, m) float, mm³
        Material per ply and element.
    lost : float, mm³
        Material of sample points outside the mesh (outside the part outline).
    resolution : float, mm
    """

    layers: Ints
    height: Floats
    weight: Floats
    fill: np.ndarray
    moments: np.ndarray
    volume: np.ndarray
    lost: float
    resolution: float
    neighbours: object = field(default=None, repr=False, compare=False)
    extra: dict = field(default_factory=dict, repr=False, compare=False)
    """Volume-weighted means per ply and element, ``(L, m)``, of the per-bead arrays passed to
    :func:`sample_deposits` as ``attributes`` (e.g. the bead model's fusion and transfer)."""

    @property
    def total_volume(self) -> float:
        """Material inside the mesh, mm³."""
        return float(np.sum(self.volume))

    def effective_fill(self) -> np.ndarray:
        """Fill the stiffness uses, ``(L, m)`` (module docstring): spread over neighbourhoods, capped."""
        if self.neighbours is None:
            return np.minimum(self.fill, 1.0)
        A, measure = self.neighbours  # (m, m) sparse 0/1 incl. the diagonal, (m,) element size
        near = (A @ self.volume.T).T / (A @ measure)[None, :] / self._ply_height()[:, None]
        return np.minimum(self.fill / np.maximum(near, 1.0), MAX_FILL)

    def _ply_height(self) -> Floats:
        return np.where(np.isfinite(self.height), self.height, 1.0)

    def mean_fill(self) -> Floats:
        """Thickness-weighted fill per element, ``(m,)``."""
        return np.einsum("l,lm->m", self.weight, self.fill)

    def direction(self) -> tuple[Floats, Floats]:
        """Dominant filament direction per element over the plies, and how dominant.

        Returns
        -------
        angle : (m,) float, rad in [0, pi)
            Half the angle of ``sum_plies weight * fill * (<cos 2t>, <sin 2t>)``.
        strength : (m,) float in [0, 1]
            Length of that mean vector over ``sum weight * fill``: 1 when every ply runs one way,
            0 for cross-plied or isotropic mixtures (e.g. 0/90 or +-45 stacks).
        """
        wf = self.weight[:, None] * np.minimum(self.fill, 1.0)
        c = np.einsum("lm,lm->m", wf, self.moments[..., 0])
        s = np.einsum("lm,lm->m", wf, self.moments[..., 1])
        tot = np.maximum(wf.sum(axis=0), 1e-300)
        return np.mod(0.5 * np.arctan2(s, c), np.pi), np.hypot(c, s) / tot


def bead_grid(beads, rows: Ints, res: float) -> tuple[np.ndarray, ...]:
    """How beads ``rows`` are sampled: each a grid of ``n_al`` points along by ``n_ac`` across.

    Parameters
    ----------
    beads : Deposits (or anything with ``start``, ``end`` (n, 2) mm, ``volume`` mm³, ``height`` mm)
    rows : (k,) int
    res : float, mm
        Largest spacing of the samples.

    Returns
    -------
    a, d : (k, 2) float, mm
        Start and start-to-end vector.
    length, width : (k,) float, mm
        The width is the one that holds the bead's volume (volume / (length * height)).
    n_al, n_ac : (k,) int
    """
    a = beads.start[rows]
    d = beads.end[rows] - a
    length = np.hypot(d[:, 0], d[:, 1])
    w = beads.volume[rows] / (length * beads.height[rows])
    n_al = np.maximum(1, np.ceil(length / res)).astype(np.int64)
    n_ac = np.maximum(1, np.ceil(w / res)).astype(np.int64)
    return a, d, length, w, n_al, n_ac


def _samples(
    dep: Deposits, rows: Ints, res: float, nz: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sample points of beads ``rows``: (points (p, 2), z (p,), bead row (p,), volume share (p,))."""
    a, d, length, w, n_al, n_ac = bead_grid(dep, rows, res)
    out_p, out_z, out_s, out_w = [], [], [], []
    for nac in np.unique(n_ac):  # beads of one width class: points along, then offsets across
        g = np.flatnonzero(n_ac == nac)
        nal = n_al[g]
        k = np.arange(int(nal.sum())) - np.repeat(np.cumsum(nal) - nal, nal)
        s = np.repeat(g, nal)
        t = (k + 0.5) / n_al[s]
        unit = d[s] / length[s, None]
        normal = np.column_stack([-unit[:, 1], unit[:, 0]]) * w[s, None]
        centre = a[s] + t[:, None] * d[s]
        off = (np.arange(nac) + 0.5) / nac - 0.5  # (nac,)
        pts = (centre[:, None, :] + off[None, :, None] * normal[:, None, :]).reshape(-1, 2)
        s = np.repeat(s, nac)
        share = dep.volume[rows][s] / (n_al[s] * nac * nz)
        for iz in range(nz):
            out_p.append(pts)
            out_z.append(dep.z0[rows][s] + (iz + 0.5) / nz * dep.height[rows][s])
            out_s.append(rows[s])
            out_w.append(share)
    return np.concatenate(out_p), np.concatenate(out_z), np.concatenate(out_s), np.concatenate(out_w)


def tet_section(mesh: MeshData, z: float) -> tuple[np.ndarray, Ints]:
    """Triangles of the section of a tetrahedral mesh by the plane ``z``, with their tetrahedron.

    Returns
    -------
    corners : (t, 3, 2) float, mm
    tet : (t,) int
        The tetrahedron each triangle lies in (a quadrilateral section gives two triangles).
    """
    c4 = mesh.cells[:, :4]
    zc = mesh.points[c4, 2] - z
    above = zc > 0
    n_up = above.sum(axis=1)
    cut = np.flatnonzero((n_up > 0) & (n_up < 4))
    if len(cut) == 0:
        return np.zeros((0, 3, 2)), np.zeros(0, dtype=np.int64)
    za, zb = zc[cut][:, _TET_EDGES[:, 0]], zc[cut][:, _TET_EDGES[:, 1]]
    crosses = (za > 0) != (zb > 0)
    t = np.divide(za, za - zb, out=np.zeros_like(za), where=crosses)
    pa = mesh.points[c4[cut][:, _TET_EDGES[:, 0]], :2]
    pb = mesh.points[c4[cut][:, _TET_EDGES[:, 1]], :2]
    p = pa + t[..., None] * (pb - pa)  # (k, 6, 2)
    cnt = crosses.sum(axis=1, keepdims=True)
    centre = np.sum(np.where(crosses[..., None], p, 0.0), axis=1) / cnt
    ang = np.where(
        crosses, np.arctan2(p[..., 1] - centre[:, None, 1], p[..., 0] - centre[:, None, 0]), np.inf
    )
    order = np.argsort(ang, axis=1)
    q = np.take_along_axis(p, order[..., None], axis=1)  # valid points first, by angle
    tris = [q[:, [0, 1, 2]]]
    tets = [cut]
    quad = cnt[:, 0] == 4
    tris.append(q[quad][:, [0, 2, 3]])
    tets.append(cut[quad])
    return np.concatenate(tris), np.concatenate(tets)


def _harmonics(angle: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(2 * angle), np.sin(2 * angle), np.cos(4 * angle), np.sin(4 * angle)], axis=1)


def sample_deposits(
    mesh: MeshData,
    deposits: Deposits,
    resolution: float = DEFAULT_RESOLUTION,
    attributes: dict[str, np.ndarray] | None = None,
) -> PlyFields:
    """Fill and direction moments of the deposits on the elements of a mesh (module docstring).

    Parameters
    ----------
    mesh : MeshData
        2D (``tri3``/``tri6``, straight-sided, ``thickness`` = the plate) or 3D (``tet4``/``tet10``).
    deposits : Deposits
    resolution : float, mm
        Distance between sample points along and across the beads.
    attributes : dict of str -> (n,) float, optional
        Per-bead quantities to average (by volume) per ply and element into ``PlyFields.extra``;
        the flow width is always averaged (``extra["width"]``).

    Returns
    -------
    PlyFields

    Raises
    ------
    GeometryError
        No material lands inside the mesh (the G-code and the mesh do not overlap).
    """
    if not resolution > 0:
        raise ValueError(f"resolution = {resolution!r} mm must be positive")
    m = len(mesh.cells)
    harm = _harmonics(deposits.angle)
    if mesh.dim == 2:
        layers, ply_of = np.unique(deposits.layer, return_inverse=True)
        n_ply = len(layers)
        heights = np.array([np.median(deposits.height[ply_of == i]) for i in range(n_ply)])
        locator = TriangleLocator(mesh.points[mesh.cells[:, :3]])
        groups = [(np.arange(len(deposits)), None)]
    else:
        layers, n_ply = np.array([-1]), 1
        heights = np.array([np.nan])
        ply_of = np.zeros(len(deposits), dtype=np.int64)
        keys = np.round(deposits.z0, 6) + 1j * np.round(deposits.height, 6)
        uk, inv = np.unique(keys, return_inverse=True)
        groups = [(np.flatnonzero(inv == i), (float(k.real), float(k.imag))) for i, k in enumerate(uk)]
    vol = np.zeros(n_ply * m)
    mom = np.zeros((n_ply * m, 4))
    attrs = {"width": deposits.flow_width, **(attributes or {})}
    acc = {k: np.zeros(n_ply * m) for k in attrs}
    lost = 0.0
    nz = 1 if mesh.dim == 2 else _Z_SAMPLES
    for rows, zrange in groups:
        sections = {}
        if zrange is not None:
            z0, h = zrange
            for iz in range(nz):
                zq = z0 + (iz + 0.5) / nz * h
                sections[round(zq, 9)] = tet_section(mesh, zq)
        # batches of beads with at most about _CHUNK sample points
        d = deposits
        est = (np.ceil(d.length[rows] / resolution) + 1) * (np.ceil(d.flow_width[rows] / resolution) + 1) * nz
        bounds = np.searchsorted(np.cumsum(est), np.arange(_CHUNK, est.sum() + _CHUNK, _CHUNK))
        for part in np.split(rows, np.unique(bounds[:-1])):
            if len(part) == 0:
                continue
            pts, z, seg, w = _samples(d, part, resolution, nz)
            if zrange is None:
                elem, _ = locator.locate(pts)
            else:
                elem = np.full(len(pts), -1, dtype=np.int64)
                for zq, (tri, tet) in sections.items():
                    sel = np.flatnonzero(np.abs(z - zq) < 1e-6)
                    if len(sel) == 0 or len(tri) == 0:
                        continue
                    found, _ = TriangleLocator(tri).locate(pts[sel])
                    ok = found >= 0
                    elem[sel[ok]] = tet[found[ok]]
            lost += accumulate(vol, mom, acc, ply_of[seg] * m + elem, elem >= 0, w, harm, attrs, seg)
    return finish(mesh, layers, heights, vol, mom, acc, lost, resolution)


def accumulate(  # type: ignore[no-untyped-def]
    vol: np.ndarray, mom: np.ndarray, acc: dict, idx: np.ndarray, inside: np.ndarray, w: np.ndarray,
    harm: np.ndarray, attrs: dict, seg: np.ndarray,
) -> float:
    """Add one batch of sample points to the per-cell sums (in place); returns the volume outside the mesh.

    ``idx`` is each point's cell (``ply * m + element``, valid where ``inside``), ``w`` its volume,
    ``seg`` its bead (a row of the per-bead ``harm``, direction harmonics, and ``attrs`` arrays).
    """
    lost = float(np.sum(w[~inside]))
    idx, wi, seg = idx[inside], w[inside], seg[inside]
    n = len(vol)
    vol += np.bincount(idx, weights=wi, minlength=n)
    for j in range(4):
        mom[:, j] += np.bincount(idx, weights=wi * harm[seg, j], minlength=n)
    for k, a in attrs.items():
        acc[k] += np.bincount(idx, weights=wi * np.asarray(a)[seg], minlength=n)
    return lost


def finish(  # type: ignore[no-untyped-def]
    mesh: MeshData, layers, heights, vol: np.ndarray, mom: np.ndarray, acc: dict, lost: float,
    resolution: float,
) -> PlyFields:
    """The :class:`PlyFields` of the per-cell sums :func:`accumulate` made (divided in place: the
    sums are spent).

    Raises
    ------
    GeometryError
        No material lands inside the mesh.
    """
    if not np.any(vol > 0):
        raise GeometryError(
            "no extruded material lies inside the part outline; the G-code and the part do not overlap"
        )
    n_ply, m = len(layers), len(mesh.cells)
    vol = vol.reshape(n_ply, m)
    has = vol > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        moments = mom.reshape(n_ply, m, 4)
        np.divide(moments, vol[..., None], out=moments, where=has[..., None])
        moments[~has] = 0.0
        extra = {}
        for k, a in acc.items():
            a = a.reshape(n_ply, m)
            np.divide(a, vol, out=a, where=has)
            a[~has] = 0.0
            extra[k] = a
    measure = np.abs(mesh.measures)
    if mesh.dim == 2:
        fill = vol / (measure[None, :] * heights[:, None])
        weight = heights / mesh.thickness
    else:
        fill = vol / measure[None, :]
        weight = np.ones(1)
    return PlyFields(
        layers.astype(np.int64),
        heights,
        weight,
        fill,
        moments,
        vol,
        lost,
        float(resolution),
        (_adjacency(mesh), measure),
        extra,
    )


def _adjacency(mesh: MeshData):  # type: ignore[no-untyped-def]
    """Elements sharing at least one corner node (each element its own neighbour), sparse 0/1 ``(m, m)``."""
    from scipy.sparse import csr_matrix

    nc = mesh.n_corners
    m = len(mesh.cells)
    rows = np.repeat(np.arange(m), nc)
    E = csr_matrix((np.ones(m * nc), (rows, mesh.cells[:, :nc].ravel())), shape=(m, len(mesh.points)))
    A = (E @ E.T).tocsr()
    A.data[:] = 1.0
    return A
