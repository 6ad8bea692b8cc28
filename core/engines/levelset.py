"""The level-set engine: a layer's paths are the level sets of one scalar field, as in the thesis's Ch. 3.

The thesis (../shared/seeds/thesis-digest.md §4.1, after Fernandez et al. 2019) lays layer i's
filaments on the level sets ``phi_i(x) = k w``: the filament angle follows ``grad phi`` (Eq. 3.2), the
spacing is ``w / |grad phi|`` (Eq. 3.3) and the local fill ``|grad phi|`` (Eq. 3.13).  It optimises
``phi``'s B-spline heights for compliance.  Here ``phi`` is fitted instead to the principal stress
the layer follows, by linear least squares on a grid over the region:

* alignment: ``grad phi . d = 0``, ``d`` the principal direction (weight ``align``), so the level
  sets run along the stress;
* spacing: ``grad phi . n = s``, ``n`` the normal to ``d``, with ``s`` (1/mm, one unknown per node)
  the line density;
* hold: ``s = s0``, ``s0 = 1 / pitch(x)`` (the nominal pitch, or the density field's, weight
  ``hold``), and ``s`` varies smoothly (weight ``smooth``).

A direction field is rarely the gradient direction of a scalar field: streamlines converge and
diverge.  The fit lets ``s`` follow (lines closer where the stress lines converge) and keeps the
alignment, which weighs most.  The level sets are then cut at ``k + phase`` (contourpy), the scale
of ``phi`` set so that their length is what the nominal (or the density field's) pitch lays in the
region.

Why level sets print well (issue 19): a level set does not end inside the region unless the field
folds there, so nearly every path runs from edge to edge and neighbouring paths end side by side
on the edge, where the shared linking stage (:mod:`loadpath.engines.linking`) joins them into
zig-zags as a slicer joins its rectilinear lines.  A density field (:mod:`loadpath.density`) is taken
as ``s0(x)`` directly: no zones and no seams between them.

Orientation and jumps.  ``d`` is sign-free; the spacing term needs a consistent ``n``.  The nodes'
normals are oriented along a minimum spanning tree of the node graph weighted by how much
neighbours disagree, so the unavoidable flips (around a degenerate point, an odd number of them on
any loop) fall where the direction is least defined.  Where the followed direction jumps (``max_abs``
across a bending neutral axis turns by 90 degrees) no scalar field has both sides' gradients: the
fit is cut there (triangles whose corners differ by more than :data:`JUMP_DEG`), each side's level
sets end on the cut, and no path runs along it.  With ``heal`` the direction is healed across the
jump instead (:func:`_healed`): the level sets run through it, along a beam's fibres.  A jump that
runs along the edge within a few pitches of it is the edge's own (a free edge's stress is uniaxial
along it): it is not cut, the inside's direction is carried on to the edge (:data:`EDGE_SKIN`).

Negligible stress (issue 15).  Where ``|sigma|`` is below ``relief`` of the field's scale (a column
loaded along its axis: the in-plane stress of every layer), its direction is noise, and following
it laid tiny loops.  There the direction is blended with the region's stress-weighted mean
direction, the alignment weighs less (down to ``relief_floor``) and ``phi``'s second differences are
held near zero (``straight``): the level sets run straight and evenly spaced.

Sparse infill (the slicer's bead width) is laid to the slicer's plastic with the links the linking
stage will print between its ends along the edge counted in (:func:`_edge_links`, an estimate): they
came on top of it, 8-18 % of the length, and the splicer printed the beads at 0.85-0.89 of the
slicer's flow (``benchmarks/printability_results.md``, twelfth and thirteenth rounds).

Solid infill (flow from the pitch).  Each vertex's pitch is measured from its neighbours
(:func:`loadpath.engines.finish.widths.local_pitch`), and where neighbouring level sets lie more
than ``split`` pitches apart, wider than a bead can print, the level set half-way between them is
laid too, in pieces at least :data:`FILL_LENGTH` pitches long.  Sparse infill (the slicer's bead
width, machine fact ``flow_width``) needs neither.  Path ends are carried on to the next bead or
the edge (:func:`loadpath.engines.finish.ends.extend_ends`) as the other engines' are.

The cut is returned as the paths' band (:attr:`Toolpaths.band`): on solid infill the linking joins
the ends on it along its edge, a zig-zag along the neutral axis, as it joins them along the faces.

Measured (``benchmarks/bench_printability.py``, real PrusaSlicer 2.5 slices, ``loadpath compare``'s
model), retractions in the replaced blocks against the slicer's, level sets (swarm), the slices of
2026-12-06: 100 % solid bar 20 -> 40 (210), beam 10 -> 65 (505), bracket 25 -> 115 (450) (on
earlier slices 50, 105 and 149 before the band and the insertions and swaps,
:mod:`loadpath.engines.insertion`), two islands 20 -> 20 (125); 40 % sparse 16 -> 28, 8 -> 44,
20 -> 44, 16 -> 16; 30 % gyroid 30 -> 18.  (On a bent part the level
sets reach the faces at a few degrees: on solid infill the linking joins them along the edge beside
the path that converges on it, ``LinkOptions.wedge``, which this engine's registry entry sets; not on
sparse infill, where it cost the 3-point beam its failure load.)  Predicted stiffness /
failure load over the slicer's at 40 %: 1.354 / 2.564, 1.367 / 1.983, 1.316 / 1.774, 1.291 / 2.460
(the swarm's 1.321 / 1.662, 1.313 / 1.811, 1.249 / 1.516, 1.235 / 1.710); 30 % gyroid 1.283 / 1.862
(1.250 / 1.207); at 100 % the failure load is lower than the swarm's on the bar (1.035 against
1.047) and the bracket (0.924 against 0.956).

(Over 400 lines: the fit assembles four kinds of least-squares rows over one grid and its
triangles; split, the grid's index arrays would be passed between modules.)
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
import shapely
from loadpath._typing import Floats, Points2, Region
from loadpath.engines.finish.ends import extend_ends
from loadpath.engines.finish.widths import local_pitch
from loadpath.errors import GeometryError, SettingsError, SolverError
from loadpath.toolpath import EngineInput, Path, Toolpaths
from scipy import sparse
from scipy.sparse import csgraph

__all__ = ["GivesWay", "LevelSetOptions", "generate", "fit", "warm_up"]

END_GAP = 0.25
"""Path ends stay this many bead widths inside the region: where a PrusaSlicer 2.5 infill line ends,
0.10 mm inside the infill domain at a 0.41 mm flow width, at 100 % and 40 % alike (the bench's
bar, ``benchmarks/bench_printability.py``).  The bead width is the slicer's flow width for sparse
infill and the nominal pitch for solid infill (the two are one there)."""

JUMP_DEG = 50.0
"""Corners of a triangle whose directions differ by more than this lie on a jump: the fit is cut there."""

CUT_WEIGHT = 0.05
"""How firmly phi keeps level on the cut (relative to the spacing term)."""

EDGE_SKIN = 3.0
"""A jump of the followed direction that lies nowhere deeper than this many nominal pitches inside
the region, and runs along its edge (:data:`SKIN_LENGTH`), in a region whose inradius is more than
twice that, is the edge's own skin, not a jump to cut the fit at: there the direction of the part's
inside is carried on to the edge (:func:`_over_skin`).  At a free edge the stress is uniaxial along
it, so where the pull across the part fades towards the edge (the end face of a grip zone) the
larger principal stress turns along the edge in the last millimetre.  Cut there, the level sets
ended 0.4-0.75 mm short of the end face of a 100-layer open-hole specimen pulled through its grip
zone (``tests/cases.py``'s ``GRIP_PULL``), their links along that face left a void beside the
perimeter on every layer, and ``loadpath compare`` predicted 0.255x the slicer's failure load, the
first ply failing at that void.  Carried over: 1.039x (stiffness 1.009x -> 1.013x), and the run's
retractions 593 -> 541, its travel 17.3 -> 16.0 m.  The linking's ``band_depth``
(:class:`loadpath.engines.linking.LinkOptions`) draws the same line for the band it links along."""

SKIN_LENGTH = 8.0
"""A jump in the edge's skin (:data:`EDGE_SKIN`) is carried over only where it runs along the edge
for at least this many times its depth (the diagonal of its nodes' box).  The hoop compression at an
open hole's flanks meets the pull in blobs about three times as long as they are deep (the 100-layer
specimen: 3.4x; the same end face: 35x): carried over there too, the level sets ran straight into the
flanks, and ``bench_printability.py``'s tension bar lost 1.3 % of its failure load against the slicer
(1.035x -> 1.022x) and its travel rose from 0.97x to 1.59x the slicer's."""

GIVE_WAY = 1.0
"""Solid infill whose cut is longer than this many times the square root of the region's area
gives way (option ``give_way``): the pipeline lays it with the swarm instead where the level sets
are only tried first (:attr:`loadpath.pipeline.PipelineOptions.solid_first`), and the run lays the
level sets there too and keeps what the mechanics model predicts better
(:mod:`loadpath.plugin.solid_choice`).  A bending
part's neutral axis runs the part's length: the cut measured 3.3, 3.1 and 5.5 on issue 15's 12 mm
beam, L-bracket and shelf bracket, where the level sets' ends on it lowered the first-ply failure
load (``benchmarks/printability_results.md``, eleventh round); around the open-hole specimen's
hole, where the hoop compression meets the pull, 0.13 (0.46 on the closed-form open hole of the
tests); the two islands in tension 0."""

HEAL = 1.0
"""The ``heal`` of the layout laid through the cut where the level sets gave way
(:mod:`loadpath.plugin.solid_choice`): a Gaussian of the region's inradius, blended over twice that
from the cut.  ``benchmarks/bench_printability.py``'s 100 % files, ``--engine levelset`` with each
``heal`` (stiffness / failure load over the slicer's, retractions in the replaced blocks; 0 is the
cut): PrusaSlicer cantilever 0: 1.024 / 0.937, 80; 0.5: 1.030 / 0.932, 35; 1: 1.028 / 0.929, 20;
2: 1.031 / 0.891, 25 (the slicer's 10); tension bar 0: 1.012 / 1.036, 40; 1: 1.011 / 0.990, 30;
L-bracket 0: 1.009 / 0.938, 108; 1: 0.941 / 0.546, 60, where the bolt hole's stress turns too and
the blend crosses it.  So it is laid as a third layout and judged, never in place of the cut."""

MAX_NODES = 60_000
"""Most grid nodes of one fit (the grid is coarsened beyond it): one sparse solve stays well under a second."""


@dataclass(frozen=True)
class LevelSetOptions:
    """How the level-set field is fitted and cut into paths (module docstring).

    Attributes
    ----------
    grid : float, mm
        Node spacing of the fit (coarsened to stay under :data:`MAX_NODES`).
    align : float
        Weight of the alignment term against the spacing term.
    hold : float
        Weight of ``s = s0`` (how firmly the density keeps to the nominal pitch).
    smooth : float
        Weight of ``s`` varying smoothly between neighbouring nodes.
    phase : float, pitches
        Level sets at ``k + phase``: 0.5 lays the staggered copy between the paths of 0.
    min_length : float, nominal pitches
        Shorter pieces are dropped.
    split : float, local pitches
        Where neighbouring level sets lie further apart, the half-way level set is laid too
        (0: never).
    pitch_range : (float, float), nominal pitches
        A vertex's pitch (``1 / |grad phi|``) is clipped to this range.
    relief : float, share of the field's scale
        Stress magnitude (``|sigma| / scale``, the sample's ``mass``) below which the alignment
        weighs less, in proportion, down to ``relief_floor`` of its weight (0: alignment weighs the
        same everywhere).  Where the stress is negligible its direction is noise (issue 15: a
        column loaded along its axis); following it lays tiny loops.
    relief_floor : float
        Least share of the alignment weight (where the stress vanishes).
    straight : float
        Weight of ``phi``'s second differences (level sets straight and evenly spaced) where the
        alignment is relieved, scaled by ``1 - share``: 0 where the stress is above ``relief``.
    quiet : float, share of the field's scale
        The relief applies only to a region whose 90th percentile of ``|sigma| / scale`` is below
        this (a near-stress-free layer); a stressed region's low-stress corners keep following the
        stress (relieving them there raised the 3-point-bend beam's retractions by half,
        ``benchmarks/bench_sparse.py``).  1 or more: every region.
    heal : float, share of the region's inradius
        0: off.  Otherwise the followed direction is healed across its jumps (:func:`_healed`):
        within ``2 heal r`` of a jump (``r`` the region's inradius, half a beam's depth) it is
        blended with its stress-weighted average over a Gaussian of ``heal r``, so on a bending
        part the level sets run through the neutral axis along the beam instead of ending on a
        cut; the run lays this as a third solid layout where the level sets gave way
        (:mod:`loadpath.plugin.solid_choice`).
    give_way : bool
        Solid infill whose fit is cut along more than :data:`GIVE_WAY` (a bending part's neutral
        axis) gets no paths: the run stops before the fit's solve and says so in its stats (``give_way``),
        and the pipeline lays that layer with another engine
        (:attr:`loadpath.pipeline.PipelineOptions.solid_first`).  False: level sets everywhere.
    """

    grid: float = 0.4
    align: float = 8.0
    hold: float = 1.0
    smooth: float = 2.0
    phase: float = 0.0
    min_length: float = 2.0
    split: float = 1.8
    pitch_range: tuple[float, float] = (0.5, 2.5)
    relief: float = 0.05
    relief_floor: float = 0.05
    straight: float = 10.0
    quiet: float = 0.25
    heal: float = 0.0
    give_way: bool = False

    def __post_init__(self) -> None:
        for name in ("grid", "align", "hold"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise SettingsError(f"{name} = {v!r}: the level-set engine needs a positive number")
        if not (np.isfinite(self.split) and (self.split == 0 or self.split > 1)):
            raise SettingsError(f"split = {self.split!r}: use 0 (off) or more than 1 pitch")
        if not (np.isfinite(self.smooth) and self.smooth >= 0):
            raise SettingsError(f"smooth = {self.smooth!r}: use 0 or a positive weight")
        for name in ("relief", "relief_floor", "straight", "quiet", "heal"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise SettingsError(f"{name} = {v!r}: use 0 (off) or a positive number")
        if self.relief_floor > 1:
            raise SettingsError(f"relief_floor = {self.relief_floor!r}: use a share between 0 and 1")
        lo, hi = self.pitch_range
        if not (0 < lo < 1 < hi):
            raise SettingsError(f"pitch_range = {self.pitch_range!r}: use (low, high) with 0 < low < 1 < high")

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> LevelSetOptions:
        """Read the options (unknown names are a one-line :class:`SettingsError`)."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(options) - names - {"flow_width"})
        if unknown:
            raise SettingsError(
                f"the level-set engine has no option {', '.join(unknown)}; its options: {', '.join(sorted(names))}"
            )
        kw: dict[str, Any] = {}
        for k in names & set(options):
            v = options[k]
            if k == "pitch_range":
                kw[k] = tuple(float(x) for x in v)
            else:
                kw[k] = bool(v) if k == "give_way" else float(v)
        return cls(**kw)


@dataclass(frozen=True)
class LevelSetFit:
    """The fitted field on its grid.

    Attributes
    ----------
    x0, y0 : float, mm
        Position of node ``[0, 0]``.
    h : float, mm
        Node spacing.
    phi : (ny, nx) float
        The field, in lines (the level sets ``phi = k`` are the paths, one local pitch apart); NaN
        off the fitted nodes.
    density : (ny, nx) float, 1/mm
        ``|grad phi|``: lines per millimetre (NaN off the fitted nodes).
    cut : Polygon or MultiPolygon
        Where the fit is cut (jumps of the direction): no path runs there (possibly empty).
    residual : float
        Relative residual of the normal equations (checked below ``1e-8``).
    cut_mm : float, mm
        The cut's length (its triangles' area over the grid spacing).
    misalignment : float, degrees
        Area-weighted mean angle between the level sets and the principal direction.
    """

    x0: float
    y0: float
    h: float
    phi: np.ndarray
    density: np.ndarray
    cut: Region
    residual: float
    misalignment: float
    cut_mm: float = 0.0

    def axes(self) -> tuple[Floats, Floats]:
        """Node coordinates along x, (nx,), and along y, (ny,), mm."""
        ny, nx = self.phi.shape
        return self.x0 + self.h * np.arange(nx), self.y0 + self.h * np.arange(ny)

    def inside(self, region: Region) -> np.ndarray:
        """(ny, nx) bool: the nodes inside ``region``."""
        px, py = np.meshgrid(*self.axes())
        return shapely.contains_xy(region, px, py)

    def sample(self, values: np.ndarray, points: Points2) -> Floats:
        """Bilinear interpolation of a node array at points (NaN nodes count as their neighbours)."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        ny, nx = values.shape
        fx = (p[:, 0] - self.x0) / self.h
        fy = (p[:, 1] - self.y0) / self.h
        ix = np.clip(np.floor(fx).astype(np.int64), 0, nx - 2)
        iy = np.clip(np.floor(fy).astype(np.int64), 0, ny - 2)
        tx = np.clip(fx - ix, 0.0, 1.0)
        ty = np.clip(fy - iy, 0.0, 1.0)
        v = np.stack([values[iy, ix], values[iy, ix + 1], values[iy + 1, ix], values[iy + 1, ix + 1]])
        w = np.stack([(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty])
        ok = np.isfinite(v)
        w = np.where(ok, w, 0.0)
        total = w.sum(axis=0)
        out = (np.where(ok, v, 0.0) * w).sum(axis=0)
        return np.where(total > 0, out / np.where(total > 0, total, 1.0), np.nan)


def _orient(n: np.ndarray, edges: np.ndarray, count: int) -> np.ndarray:
    """Signs (+1/-1) that orient the nodes' normals consistently along a minimum spanning tree.

    Parameters
    ----------
    n : (m, 2) float
        Unit normals (sign arbitrary) of the active nodes.
    edges : (e, 2) int
        Neighbouring active nodes.
    count : int
        m.
    """
    dots = np.einsum("ij,ij->i", n[edges[:, 0]], n[edges[:, 1]])
    cost = 1.0 - np.abs(dots) + 1e-6
    graph = sparse.coo_matrix((cost, (edges[:, 0], edges[:, 1])), shape=(count, count)).tocsr()
    tree = csgraph.minimum_spanning_tree(graph)
    tree = tree + tree.T
    tree = tree.tocoo()
    flip = np.einsum("ij,ij->i", n[tree.row], n[tree.col]) < 0
    # parity of flips on the tree path from each component's root: flipped tree edges weigh 1,
    # kept ones a tiny positive amount, so the path length rounds to the number of flips
    w = np.where(flip, 1.0, 1e-7)
    g = sparse.coo_matrix((w, (tree.row, tree.col)), shape=(count, count)).tocsr()
    # one search from every component's first node: the others' roots are out of reach, so each
    # node's shortest distance is the one from its own root
    _, labels = csgraph.connected_components(g, directed=False)
    _, roots = np.unique(labels, return_index=True)
    dist = csgraph.dijkstra(g, indices=roots, directed=False, min_only=True)
    parity = np.rint(dist).astype(np.int64) % 2
    return np.where(parity == 1, -1.0, 1.0)


def _inradius(inside: np.ndarray, h: float) -> float:
    """The largest distance of a node inside (``inside`` (ny, nx) bool) from every node outside, mm."""
    from scipy import ndimage

    return float(ndimage.distance_transform_edt(inside).max()) * h


def _nearest(source: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(iy, ix)``, each (ny, nx) int: for every grid node, the nearest node of ``source`` (ny, nx) bool."""
    from scipy import ndimage

    _, (iy, ix) = ndimage.distance_transform_edt(~source, return_indices=True)
    return iy, ix


def _over_skin(
    q: np.ndarray, cut: np.ndarray, tri: np.ndarray, act: np.ndarray, inside: np.ndarray, nodes: Points2,
    h: float, region: Region, depth: float,
) -> np.ndarray | None:
    """The nodes' direction doubles with the inside's direction carried over the edge's skin
    (:data:`EDGE_SKIN`); None where no jump lies there.

    Parameters
    ----------
    q : (ny nx, 2) float
        Every grid node's direction double ``(cos 2t, sin 2t)`` (scaled by how defined it is).
    cut : (t,) bool
        The triangles on a jump.
    tri : (t, 3) int
        Their nodes, as indices into ``act``.
    act : (m,) int
        The active nodes' flat grid indices.
    inside : (ny, nx) bool
        The nodes inside the region.
    nodes : (ny nx, 2) float, mm
    h : float, mm
        The grid's node spacing.
    region : Polygon or MultiPolygon, mm
    depth : float, mm
        The skin's depth.

    Returns
    -------
    (ny nx, 2) float or None
        A piece of the cut (8-neighbours) with no node deeper than ``depth`` inside the region,
        at least :data:`SKIN_LENGTH` times as long as that, is the edge's own.  Around each, the
        nodes within ``depth`` of the edge whose direction turns more than :data:`JUMP_DEG` from the
        nearest deeper node's (the jump and the skin beyond it, up to the edge) take that node's
        direction, and the nodes outside the region their nearest inside node's.  None when no
        piece lies in the skin, or the region's inradius is at most ``2 depth`` (a narrow part's
        jump lies near its edge everywhere: it stays cut).
    """
    from scipy import ndimage

    if not cut.any():
        return None
    shape = inside.shape
    if _inradius(inside, h) <= 2.0 * depth:
        return None
    edge = shapely.boundary(region)
    shapely.prepare(edge)
    flat = inside.ravel()
    dist = np.zeros(len(flat))
    dist[flat] = shapely.distance(edge, shapely.points(nodes[flat]))
    dist = dist.reshape(shape)
    on = np.zeros(flat.size, dtype=bool)
    on[act[np.unique(tri[cut])]] = True
    on = on.reshape(shape)
    eight = np.ones((3, 3), dtype=bool)
    labels, count = ndimage.label(on, structure=eight)
    deepest = np.zeros(count + 1)
    np.maximum.at(deepest, labels[on], np.where(inside[on], dist[on], 0.0))
    # each piece's extent: the diagonal of its nodes' bounding box
    xy = nodes.reshape(*shape, 2)[on]
    lo = np.full((count + 1, 2), np.inf)
    hi = np.full((count + 1, 2), -np.inf)
    np.minimum.at(lo, labels[on], xy)
    np.maximum.at(hi, labels[on], xy)
    extent = np.hypot(*np.where(np.isfinite(hi - lo), hi - lo, 0.0).T)
    strip = (deepest <= depth) & (extent >= SKIN_LENGTH * np.maximum(deepest, h))
    skin = strip[labels] & on
    deep = inside & (dist > depth)
    if not skin.any() or not deep.any():
        return None
    qg = q.reshape(*shape, 2)
    ref = qg[_nearest(deep)]  # the nearest node deeper than the skin
    # the double angles turn by more than twice the jump's
    dot = np.einsum("...i,...i->...", qg, ref)
    size = np.linalg.norm(qg, axis=-1) * np.linalg.norm(ref, axis=-1)
    turned = dot < np.cos(np.radians(2.0 * JUMP_DEG)) * size
    near = (inside & ~deep & turned) | skin
    labels, _ = ndimage.label(near, structure=eight)
    zone = np.isin(labels, np.unique(labels[skin])) & inside
    out = qg.copy()
    out[zone] = ref[zone]
    out = out[_nearest(inside)]  # outside the region: the nearest inside node's, as the fit's margin
    return out.reshape(-1, 2)


class GivesWay(Exception):
    """Raised by :func:`fit` before the solve when the cut is longer than ``give_way_mm``."""

    def __init__(self, cut_mm: float) -> None:
        super().__init__(f"the level-set fit is cut along {cut_mm:.1f} mm")
        self.cut_mm = cut_mm


def _healed(q: np.ndarray, mass: np.ndarray, inside: np.ndarray, h: float, heal: float) -> np.ndarray:
    """The doubled-angle direction field ``q`` healed across its jumps (option ``heal``).

    Parameters
    ----------
    q : (ny, nx, 2) float
        ``(cos 2t, sin 2t)`` of the followed direction at each node (filled outside the part).
    mass : (ny, nx) float
        Stress magnitude over the field's scale (0 where undefined).
    inside : (ny, nx) bool
        Nodes inside the part.
    h : float, mm
        Node spacing.
    heal : float
        Gaussian width, as a share of the region's inradius.

    Returns
    -------
    (ny, nx, 2) float
        Unit doubled-angle vectors: ``q`` itself further than ``2 heal r`` from a jump (neighbours
        whose directions differ by more than :data:`JUMP_DEG`), blended linearly towards the
        stress-weighted Gaussian average of ``q`` on the jump.  On a bending part's neutral axis
        the shear's +-45 degrees of each side cancel in the average, and the fibres' stress along
        the beam, the larger, sets the direction.
    """
    from scipy import ndimage

    lim = np.cos(np.radians(2 * JUMP_DEG))
    jump = np.zeros(inside.shape, dtype=bool)
    across = (q[:, 1:] * q[:, :-1]).sum(axis=-1) < lim
    jump[:, 1:] |= across
    jump[:, :-1] |= across
    across = (q[1:, :] * q[:-1, :]).sum(axis=-1) < lim
    jump[1:, :] |= across
    jump[:-1, :] |= across
    jump &= inside
    if not jump.any():
        return q
    sigma = heal * _inradius(inside, h)
    # ``mass`` outside the part is 0: its filled directions weigh nothing
    avg = np.stack([ndimage.gaussian_filter(q[..., k] * mass, sigma / h, mode="nearest") for k in (0, 1)], -1)
    avg /= np.maximum(np.hypot(avg[..., 0], avg[..., 1]), 1e-300)[..., None]
    b = np.clip(1.0 - ndimage.distance_transform_edt(~jump) * h / (2.0 * sigma), 0.0, 1.0)[..., None]
    out = b * avg + (1.0 - b) * q
    return out / np.maximum(np.hypot(out[..., 0], out[..., 1]), 1e-300)[..., None]


def fit(inp: EngineInput, options: LevelSetOptions, give_way_mm: float = np.inf) -> LevelSetFit:
    """Fit the level-set field of one region (module docstring).

    Parameters
    ----------
    inp : EngineInput
        Region, field (already the principal stress to follow), nominal pitch and optional density.
    options : LevelSetOptions
    give_way_mm : float, mm
        Stop before the solve, raising :class:`GivesWay`, when the cut is longer (option
        ``give_way``: the pipeline lays that layer with another engine).

    Returns
    -------
    LevelSetFit

    Raises
    ------
    SolverError
        The sparse solve's residual is not small (checked, never ignored).
    """
    region = inp.region
    p0 = float(inp.pitch)
    x0, y0, x1, y1 = region.bounds
    h = max(options.grid, float(np.sqrt((x1 - x0 + 4 * options.grid) * (y1 - y0 + 4 * options.grid) / MAX_NODES)))
    gx0, gy0 = x0 - 2 * h, y0 - 2 * h
    nx = int(np.ceil((x1 - x0) / h)) + 5
    ny = int(np.ceil((y1 - y0) / h)) + 5
    xs = gx0 + h * np.arange(nx)
    ys = gy0 + h * np.arange(ny)
    px, py = np.meshgrid(xs, ys)
    nodes = np.stack([px.ravel(), py.ravel()], axis=1)
    # nodes of the cells that touch the region (one cell of margin so level sets reach the edge)
    near = region.buffer(1.5 * h)
    shapely.prepare(near)
    active = shapely.contains_xy(near, nodes[:, 0], nodes[:, 1]).reshape(ny, nx)
    smp = inp.field.sample(nodes)
    d = np.where(np.isfinite(smp.direction), smp.direction, 0.0)
    # the field's direction outside the part (nodes of the margin): the nearest inside node's
    q = np.stack([d[:, 0] ** 2 - d[:, 1] ** 2, 2 * d[:, 0] * d[:, 1]], axis=1) * smp.valid[:, None]
    # share of the alignment weight kept: 1 where the stress is above ``relief`` of the field's
    # scale, falling in proportion to ``relief_floor`` where it vanishes (its direction is noise)
    mass = np.where(np.isfinite(smp.mass), smp.mass, 0.0)
    loud = float(np.percentile(mass[smp.inside], 90)) if np.any(smp.inside) else 0.0
    if options.relief > 0 and (options.quiet >= 1 or loud < options.quiet):
        share = np.clip(mass / options.relief, options.relief_floor, 1.0)
    else:
        share = np.ones(len(nodes))
    inside = smp.inside.reshape(ny, nx)
    if np.any(inside) and not np.all(inside):
        iy, ix = _nearest(inside)
        q = q.reshape(ny, nx, 2)[iy, ix].reshape(-1, 2)
        share = share.reshape(ny, nx)[iy, ix].ravel()
    if options.relief > 0 and np.any(share < 1):
        # where the stress is negligible its direction is noise: it is blended (by ``1 - share``)
        # with the region's mean direction, weighted by the stress, so the level sets there run on
        # straight (a region with no stress at all: the x axis, as a slicer's first layer)
        wq = share * smp.valid
        qbar = (q * wq[:, None]).sum(axis=0) / max(float(wq.sum()), 1e-300)
        nb = float(np.hypot(*qbar))
        qbar = qbar / nb if nb > 1e-3 else np.array([1.0, 0.0])
        q = share[:, None] * q + (1.0 - share[:, None]) * qbar[None, :]
    if options.heal > 0 and np.any(inside):
        q = _healed(q.reshape(ny, nx, 2), np.where(np.isfinite(smp.mass), smp.mass, 0.0).reshape(ny, nx),
                    inside, h, options.heal).reshape(-1, 2)
    if inp.density is not None:
        scale = p0 / inp.density.base_pitch
        s0 = 1.0 / (inp.density.pitch_at(nodes) * scale)
    else:
        s0 = np.full(len(nodes), 1.0 / p0)

    idx = -np.ones(ny * nx, dtype=np.int64)
    act = np.flatnonzero(active.ravel())
    if len(act) < 4:
        raise GeometryError("the replace region is smaller than the level-set engine's grid; use a finer grid")
    m = len(act)
    idx[act] = np.arange(m)
    grid_idx = idx.reshape(ny, nx)
    # grid edges between active nodes
    eh = np.stack([grid_idx[:, :-1].ravel(), grid_idx[:, 1:].ravel()], axis=1)
    ev = np.stack([grid_idx[:-1, :].ravel(), grid_idx[1:, :].ravel()], axis=1)
    edges = np.concatenate([eh, ev])
    edges = edges[(edges >= 0).all(axis=1)]
    share_act = share[act]

    # two triangles per cell whose corners are all active: (a, b, c) with grad = ((b-a), (c-a)) / h
    # (lower: a = (i, j), b = (i+1, j), c = (i, j+1)); upper: a' = (i+1, j+1), with minus signs
    c00 = grid_idx[:-1, :-1].ravel()
    c10 = grid_idx[:-1, 1:].ravel()
    c01 = grid_idx[1:, :-1].ravel()
    c11 = grid_idx[1:, 1:].ravel()
    full = (c00 >= 0) & (c10 >= 0) & (c01 >= 0) & (c11 >= 0)
    c00, c10, c01, c11 = c00[full], c10[full], c01[full], c11[full]
    # each triangle: gx = (gxp - gxm)/h, gy = (gyp - gym)/h, nodes of the triangle (tri)
    gxp = np.concatenate([c10, c11])
    gxm = np.concatenate([c00, c01])
    gyp = np.concatenate([c01, c11])
    gym = np.concatenate([c00, c10])
    tri = np.stack([np.concatenate([c00, c11]), np.concatenate([c10, c01]), np.concatenate([c01, c10])], axis=1)
    nt = len(tri)
    if nt == 0:
        raise GeometryError("the replace region is narrower than the level-set engine's grid; use a finer grid")

    def along(q: np.ndarray) -> tuple[np.ndarray, ...]:
        """The nodes' direction doubles ``q`` (ny nx, 2) read on the active nodes and triangles:
        the oriented normals, each triangle's mean normal, its agreement and definedness, and the
        triangles on a jump (a jump of the followed direction, max_abs across a neutral axis, or a
        fold: the fit is cut there, so the level sets of each side end on the cut instead of
        flattening a band around it)."""
        t = 0.5 * np.arctan2(q[:, 1], q[:, 0])
        nvec = np.stack([-np.sin(t), np.cos(t)], axis=1)
        n_act = nvec[act] * _orient(nvec[act], edges, m)[:, None]
        nsum = n_act[tri].sum(axis=1) / 3.0
        agree = np.hypot(nsum[:, 0], nsum[:, 1])  # 1: the corners agree; ~0 across a flip
        qt = np.hypot(q[act, 0], q[act, 1])[tri].mean(axis=1)
        nn = n_act[tri]
        pairs = ((0, 1), (0, 2), (1, 2))
        spread = np.min(np.abs(np.stack([np.einsum("ij,ij->i", nn[:, a], nn[:, b]) for a, b in pairs])), axis=0)
        return nsum, agree, qt, spread < np.cos(np.radians(JUMP_DEG))

    nsum, agree, qt, cut = along(q)
    # a jump that lies wholly in the edge's skin is the edge's own: the inside's direction carried over it
    carried = _over_skin(q, cut, tri, act, inside, nodes, h, region, EDGE_SKIN * p0)
    if carried is not None:
        q = carried
        nsum, agree, qt, cut = along(q)
    nt_vec = nsum / np.maximum(agree, 1e-12)[:, None]
    dt_vec = np.stack([nt_vec[:, 1], -nt_vec[:, 0]], axis=1)
    # its length: the cut triangles' area (h^2 / 2 each) over the grid spacing
    cut_mm = 0.5 * h * float(np.count_nonzero(cut))
    if cut_mm > give_way_mm:
        raise GivesWay(cut_mm)
    agree = np.where(cut, 0.0, agree)
    # rows are scaled by the nominal pitch so every term is dimensionless
    rows: list[sparse.coo_matrix] = []
    rhs: list[np.ndarray] = []
    r = np.arange(nt)

    def grad_rows(vec: np.ndarray, weight: np.ndarray) -> sparse.coo_matrix:
        cx = weight * vec[:, 0] * p0 / h
        cy = weight * vec[:, 1] * p0 / h
        data = np.concatenate([cx, -cx, cy, -cy])
        cols = np.concatenate([gxp, gxm, gyp, gym])
        return sparse.coo_matrix((data, (np.tile(r, 4), cols)), shape=(nt, 2 * m))

    st = share_act[tri].mean(axis=1)
    wa = np.sqrt(options.align) * qt * agree * st
    rows.append(grad_rows(dt_vec, wa))
    rhs.append(np.zeros(nt))
    ws = agree * np.maximum(qt, 0.2)
    spacing = grad_rows(nt_vec, ws)
    sdat = np.repeat(-ws * p0 / 3.0, 3)
    spacing = spacing + sparse.coo_matrix((sdat, (np.repeat(r, 3), m + tri.ravel())), shape=(nt, 2 * m))
    rows.append(spacing.tocoo())
    rhs.append(np.zeros(nt))
    # on the cut, phi only keeps level (a faint pull of its gradient to 0)
    wc = np.where(cut, CUT_WEIGHT, 0.0)
    for axis in ((1.0, 0.0), (0.0, 1.0)):
        rows.append(grad_rows(np.tile(axis, (nt, 1)), wc))
        rhs.append(np.zeros(nt))
    wh = np.sqrt(options.hold)
    rows.append(sparse.coo_matrix((np.full(m, wh * p0), (np.arange(m), m + np.arange(m))), shape=(m, 2 * m)))
    rhs.append(wh * p0 * s0[act])
    if options.smooth > 0:
        ws2 = np.sqrt(options.smooth) * p0 * np.ones(len(edges))
        e = np.arange(len(edges))
        rows.append(
            sparse.coo_matrix(
                (np.concatenate([ws2, -ws2]), (np.tile(e, 2), m + edges.T.ravel())), shape=(len(edges), 2 * m)
            )
        )
        rhs.append(np.zeros(len(edges)))
    # where the alignment is relieved, phi's second differences vanish: straight, even level sets
    if options.straight > 0 and options.relief > 0:
        for a3 in (
            (grid_idx[:, :-2], grid_idx[:, 1:-1], grid_idx[:, 2:]),
            (grid_idx[:-2, :], grid_idx[1:-1, :], grid_idx[2:, :]),
        ):
            i0, i1, i2 = (x.ravel() for x in a3)
            ok = (i0 >= 0) & (i1 >= 0) & (i2 >= 0)
            i0, i1, i2 = i0[ok], i1[ok], i2[ok]
            wl = np.sqrt(options.straight) * (1.0 - share_act[i1]) * p0 / h
            sel = wl > 0
            i0, i1, i2, wl = i0[sel], i1[sel], i2[sel], wl[sel]
            k = np.arange(len(wl))
            rows.append(
                sparse.coo_matrix(
                    (np.concatenate([wl, -2 * wl, wl]), (np.tile(k, 3), np.concatenate([i0, i1, i2]))),
                    shape=(len(wl), 2 * m),
                )
            )
            rhs.append(np.zeros(len(wl)))
    # phi is defined up to a constant: a faint pull towards 0 makes the system regular
    rows.append(sparse.coo_matrix((np.full(m, 1e-6), (np.arange(m), np.arange(m))), shape=(m, 2 * m)))
    rhs.append(np.zeros(m))
    a = sparse.vstack(rows).tocsr()
    b = np.concatenate(rhs)
    lhs = (a.T @ a).tocsc()
    rvec = a.T @ b
    from loadpath.fea.solver import symmetric_lu  # not at import: loadpath.fea loads the analysis

    try:
        sol = symmetric_lu(lhs).solve(rvec)
    except RuntimeError as exc:  # SuperLU: singular, or out of memory
        raise SolverError(f"the level-set fit did not solve ({exc}); report this part") from None
    # Every other row sees only differences of phi, so the pull's exact minimiser has mean(phi) = 0.
    # The direct solve holds that constant only to about 1e-3 lines (the pull is the matrix's 1e-12
    # eigenvalue) and by a different amount with each ordering: set here, the level sets no longer
    # move by a fraction of a micrometre with the solver (the nineteenth round of
    # benchmarks/printability_results.md: such a shift alone moved that bench both ways).
    sol[:m] -= sol[:m].mean()
    res = float(np.linalg.norm(lhs @ sol - rvec) / max(np.linalg.norm(rvec), 1e-300))
    if not np.isfinite(res) or res > 1e-8:
        raise SolverError(f"the level-set fit did not solve (relative residual {res:.2e}); report this part")
    phi = np.full(ny * nx, np.nan)
    phi[act] = sol[:m]
    phi = phi.reshape(ny, nx)
    # |grad phi| per triangle, spread to its nodes (area mean)
    gx = (sol[gxp] - sol[gxm]) / h
    gy = (sol[gyp] - sol[gym]) / h
    gmag = np.hypot(gx, gy)
    acc = np.bincount(tri.ravel(), np.repeat(gmag, 3), minlength=m)
    cnt = np.bincount(tri.ravel(), minlength=m)
    dens = np.full(ny * nx, np.nan)
    dens[act] = np.where(cnt > 0, acc / np.maximum(cnt, 1), np.nan)
    cosang = np.abs(gx * dt_vec[:, 0] + gy * dt_vec[:, 1]) / np.maximum(gmag, 1e-12)
    ang = np.degrees(np.arcsin(np.clip(cosang, 0.0, 1.0)))
    keep = qt > 0.3
    mis = float(np.average(ang[keep], weights=gmag[keep])) if np.any(keep) and gmag[keep].sum() > 0 else 0.0
    if np.any(cut):
        xy = nodes[act][tri[cut]]  # (k, 3, 2)
        band = shapely.union_all(shapely.polygons(xy)).buffer(0.05 * h)
    else:
        band = shapely.Polygon()
    return LevelSetFit(gx0, gy0, h, phi, dens.reshape(ny, nx), band, res, mis, cut_mm)


def _contours(f: LevelSetFit, phase: float, scale: float = 1.0) -> list[np.ndarray]:
    """The level sets ``scale * phi = k + phase`` as polylines (mm)."""
    import contourpy

    xs, ys = f.axes()
    z = np.ma.masked_invalid(scale * f.phi)
    lo, hi = float(np.nanmin(z)), float(np.nanmax(z))
    levels = np.arange(np.floor(lo - phase) + phase, hi + 1.0, 1.0)
    gen = contourpy.contour_generator(xs, ys, z, line_type=contourpy.LineType.Separate)
    out: list[np.ndarray] = []
    for lev in levels:
        out.extend(np.asarray(seg, dtype=float) for seg in gen.lines(float(lev)) if len(seg) >= 2)
    return out


def _clip(lines: list[np.ndarray], region: Region) -> list[np.ndarray]:
    """The pieces of the polylines inside the region."""
    if not lines:
        return []
    geoms = shapely.intersection(np.array([shapely.LineString(ln) for ln in lines], dtype=object), region)
    parts = shapely.get_parts(geoms)
    parts = parts[shapely.get_type_id(parts) == 1]
    return [np.asarray(shapely.get_coordinates(g)) for g in parts if not g.is_empty]


MATCH_STEPS = 4
"""Most contourings while the paths' length is brought to the target (each rescales ``phi``)."""

MATCH_TOLERANCE = 0.005
"""Relative length error accepted (the splicer then corrects the last per cent by the flow)."""


def _integral(f: LevelSetFit, values: np.ndarray, region: Region) -> float:
    """Integral of a node array over a region: the sum over the nodes inside times the cell area."""
    inside = f.inside(region) & np.isfinite(values)
    return float(np.sum(values[inside]) * f.h * f.h)


def _target_length(f: LevelSetFit, inp: EngineInput) -> float:
    """Path length (mm) that lays the region at its nominal or density-field pitch: sum of s0 dA."""
    region = inp.region
    if inp.density is None:
        return float(region.area / inp.pitch)
    px, py = np.meshgrid(*f.axes())
    inside = shapely.contains_xy(region, px, py)
    pts = np.stack([px[inside], py[inside]], axis=1)
    if len(pts) == 0:
        return float(region.area / inp.pitch)
    local = inp.density.pitch_at(pts) * inp.pitch / inp.density.base_pitch
    # the nodes' mean line density times the exact area
    return float(region.area * np.mean(1.0 / local))


FILL_LENGTH = 5.0
"""Shortest half-way piece, nominal pitches: a shorter one costs a travel for too little area."""


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges ``[a, b)`` of the true runs of a boolean array."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def _long(lines: list[np.ndarray], length: float) -> list[np.ndarray]:
    """The polylines at least ``length`` mm long, in one vectorized pass (clipped, a shorter line
    gives only shorter pieces): :func:`_paths` drops the others one by one, after sampling the field
    on them.  A stress that is noise (``relief = 0`` on a column loaded along its axis, 16 x 12 mm)
    contours into ~170,000 tiny loops, and the cut through the noise clips the rest into as many
    pieces: taken one by one they took 86 s of the layer's 87."""
    if not lines:
        return lines
    line = np.repeat(np.arange(len(lines)), [len(ln) for ln in lines])
    same = line[1:] == line[:-1]  # the steps within a line, not from one line to the next
    step = np.hypot(*np.diff(np.concatenate(lines), axis=0).T)
    total = np.bincount(line[1:][same], weights=step[same], minlength=len(lines))
    return [ln for ln, t in zip(lines, total, strict=True) if t >= length]


def _paths(
    f: LevelSetFit, inp: EngineInput, o: LevelSetOptions, inset: Region, scale: float
) -> tuple[list[Path], float]:
    """The level sets of ``scale * phi`` inside ``inset``, as paths, and their total length (mm).

    Where neighbouring level sets lie more than ``o.split`` local pitches apart, the level set
    half-way between them is laid too (kind ``"fill"``): the beads could not tile that gap.
    """
    p0 = float(inp.pitch)
    if inset.is_empty:
        return [], 0.0
    phase = o.phase % 1.0
    shortest = o.min_length * p0
    main = _long(_clip(_long(_contours(f, phase, scale), shortest), inset), shortest)
    half = []
    if o.split > 0:
        shortest = FILL_LENGTH * p0
        half = _long(_clip(_long(_contours(f, (phase + 0.5) % 1.0, scale), shortest), inset), shortest)
    lo, hi = o.pitch_range
    paths: list[Path] = []
    total = 0.0
    for kind, lines in (("continuous", main), ("fill", half)):
        for ln in lines:
            dens = scale * f.sample(f.density, ln)
            pitch = np.where(np.isfinite(dens) & (dens > 0), 1.0 / np.maximum(dens, 1e-12), p0)
            local: Floats | float = p0
            if inp.density is not None:
                local = inp.density.pitch_at(ln) * p0 / inp.density.base_pitch
            pieces = [(0, len(ln))]
            if kind == "fill":
                pieces = [(a, b) for a, b in _runs(pitch > o.split * local) if b - a >= 2]
            for a, b in pieces:
                seg = ln[a:b]
                length = float(np.hypot(*np.diff(seg, axis=0).T).sum())
                if length < (FILL_LENGTH if kind == "fill" else o.min_length) * p0:
                    continue
                pp = np.clip(pitch[a:b] / (2.0 if kind == "fill" else 1.0), lo * p0, hi * p0)
                paths.append(Path(points=np.ascontiguousarray(seg), pitch=np.ascontiguousarray(pp), kind=kind))
                total += length
    return paths, total


def _edge_links(paths: list[Path], region: Region, pitch: float) -> float:
    """Length the linking will print between the paths' ends along the edge, estimated, mm.

    Each end within the linking's ``edge_reach`` of the edge is linked to its nearest neighbouring
    end there (the slicer's zig-zag connection): half the sum of those distances, each at most the
    linking's ``max_edge_link`` (:class:`loadpath.engines.linking.LinkOptions`' defaults).
    """
    if len(paths) < 2:
        return 0.0
    from loadpath.engines.linking import LinkOptions
    from scipy.spatial import cKDTree

    lo = LinkOptions()
    ends = np.array([p.points[i] for p in paths for i in (0, -1)])
    near = shapely.distance(region.boundary, shapely.points(ends)) <= lo.edge_reach * pitch
    e = ends[near]
    if len(e) < 2:
        return 0.0
    d, _ = cKDTree(e).query(e, k=2)
    gap = d[:, 1]
    return float(0.5 * gap[gap <= lo.max_edge_link * pitch].sum())


def generate(inp: EngineInput, **options: Any) -> Toolpaths:
    """Level-set paths for one region (the engine contract of ``loadpath.engines``).

    Parameters
    ----------
    inp : EngineInput
        Region, field (the principal stress to follow), nominal pitch, optional density field.
    **options
        :class:`LevelSetOptions` fields (``phase = 0.5``: the staggered copy), and ``flow_width``
        (mm; the machine fact: set for sparse infill printed at the slicer's bead width).

    Returns
    -------
    Toolpaths
        Paths in no particular order (the shared linking stage joins and orders them); ``pitch`` per
        vertex ``1 / |grad phi|``; ``stats``: times (s), the fit's residual and misalignment
        (degrees), path counts and length.
    """
    o = LevelSetOptions.from_options(options)
    # sparse infill keeps the slicer's bead width: its pitch sets only where the lines go, so no
    # half-way lines and no widths measured to tile
    fixed = options.get("flow_width") is not None
    if fixed:
        o = replace(o, split=0.0)
    region = inp.region
    if region.geom_type not in ("Polygon", "MultiPolygon") or not region.is_valid:
        raise GeometryError(
            f"the replace region is a {'invalid ' if not region.is_valid else ''}{region.geom_type}; "
            "the level-set engine needs a valid Polygon or MultiPolygon (try region.buffer(0))"
        )
    p0 = float(inp.pitch)
    # the ends' distance from the edge follows the bead, not the line spacing: a quarter pitch of
    # 20 % sparse infill held every line end 0.5 mm off the perimeter, five times the slicer's gap
    gap = END_GAP * (float(options["flow_width"]) if fixed else p0)
    t0 = time.perf_counter()
    limit = GIVE_WAY * float(np.sqrt(region.area)) if o.give_way and not fixed else np.inf
    try:
        f = fit(inp, o, give_way_mm=limit)
    except GivesWay as gw:  # a bending part's neutral axis: the pipeline lays this one otherwise
        took = time.perf_counter() - t0
        return Toolpaths(paths=(), stats={"times_s": {"fit": took, "total": took}, "give_way": True,
                                          "cut_mm": round(gw.cut_mm, 2)})
    t1 = time.perf_counter()
    inset = region.buffer(-gap)
    if not f.cut.is_empty:
        inset = inset.difference(f.cut)
    # the length the nominal (or the density field's) pitch lays in the region: the line density
    # integrated over the region's nodes
    target = _target_length(f, inp)
    # first guess by the coarea formula: the level sets k = 0, 1, 2 ... of scale * phi are about
    # scale * (integral of |grad phi| over the region) long, so one or two contourings suffice
    coarea = _integral(f, f.density, inset)
    scale = target / coarea if coarea > 0 else 1.0
    steps = 0
    paths: list[Path] = []
    total = 0.0
    # the scale is matched on the level sets of phase 0, so a staggered copy (phase 0.5) lies
    # half-way between the paths of the layers it alternates with
    base = replace(o, phase=0.0)
    links = 0.0
    for step in range(MATCH_STEPS):
        paths, total = _paths(f, inp, base, inset, scale)
        steps += 1
        # sparse infill: the links the linking stage will print along the edge count against the
        # slicer's plastic too (issue 15: on top of the lines they were 8-18 % of it)
        links = _edge_links(paths, region, p0) if fixed else 0.0
        have = total + links
        if have <= 0 or abs(have / target - 1.0) <= MATCH_TOLERANCE or step == MATCH_STEPS - 1:
            break
        scale *= target / have
    if o.phase % 1.0:
        paths, total = _paths(f, inp, o, inset, scale)
    # each vertex's pitch measured from its neighbours (the fit's 1 / |grad phi| misses at ends and
    # on the cut; the level sets are evenly spaced, so no centring), the ends carried on to the
    # next bead
    t_f = time.perf_counter()
    if paths:
        pts = [p.points for p in paths]
        w = [p.pitch for p in paths]
        if not fixed:
            # the ends carried on with the widths as measured without the ends' correction, then
            # measured again with it (``local_pitch(ends=True)``): carried on with the corrected,
            # narrower widths they ran up to 1.3 mm further into the wedges at the cut and at the
            # edge, where the links then found less room (bench_printability, PrusaSlicer 100 %,
            # retractions: bar 40 -> 45, L-bracket 108 -> 120, taper 83 -> 92)
            w = local_pitch(pts, region, p0, cap=o.pitch_range[1])
        pts, w, ends = extend_ends(pts, w, region, p0, edge_gap=gap / p0, field=inp.field, cap=0.0, overlap=0.0)
        if not fixed:
            w = local_pitch(pts, region, p0, cap=o.pitch_range[1], ends=True)
        paths = [Path(points=q, pitch=wi, kind=p.kind) for q, wi, p in zip(pts, w, paths, strict=True)]
    else:
        ends = {}
    t2 = time.perf_counter()
    stats = {
        "times_s": {"fit": t1 - t0, "contours": t_f - t1, "finish": t2 - t_f, "total": t2 - t0},
        "residual": f.residual,
        "misalignment_deg": round(f.misalignment, 3),
        "grid_mm": f.h,
        "n_paths": len(paths),
        "length_mm": round(total, 2),
        "edge_links_mm": round(links, 2),
        "cut_mm": round(f.cut_mm, 2),
        "give_way": False,
        "length_target_mm": round(target, 2),
        "density_scale": round(scale, 4),
        "contourings": steps,
        **{k: v for k, v in ends.items() if isinstance(v, (int, float))},
    }
    return Toolpaths(paths=tuple(paths), stats=stats, band=None if f.cut.is_empty else f.cut)


def warm_up() -> float:
    """Load the compiled finishing kernels the engine calls (numba) by running it on a tiny layer.

    Run before workers fork (:func:`loadpath.engines.registry.warm_up`), so they inherit the kernels:
    each worker otherwise loaded them itself on its first level-set job, about 0.4 s apiece.
    Returns the seconds it took.
    """
    from loadpath.engines.registry import Machine, generate as run
    from loadpath.field import AnalyticField, kirsch_tensor
    from shapely.geometry import Point, box

    t0 = time.perf_counter()
    region = box(0, 0, 12, 6).difference(Point(6, 3).buffer(1.0))
    field = AnalyticField(lambda p: kirsch_tensor(p, (6, 3), 1.0, 1.0), region, scale=6.0)
    run("levelset", EngineInput(region, field, 1.5), machine=Machine(flow_width=0.45))
    return time.perf_counter() - t0
