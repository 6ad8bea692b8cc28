r"""The stiffest any layout of a given plastic can be in the model, with a certificate (issue 15).

Issue 15 asks sparse infill laid at the slicer's mass to be at least 1.5x as stiff as the slicer's.
Whether any layout can be, in the model that judges it (:func:`~.predict.predict`), is a convex
question, and this module answers it with a bound that holds for every layout, not an estimate.

The design.  The walls and skins stay as sliced: their per-element stiffness ``D_fixed`` (MPa, the
stack mean of :func:`~.predict.material_matrices`).  A plastic volume ``V`` (mm³) is spread over
the layers that hold the sparse infill (their share ``s = t_s / t`` of the plate's thickness): fill
``rho_e`` in ``[0, 1]`` per element ``e`` of area ``A_e``, at most solid, adds ``s rho_e C_e``
with ``sum_e rho_e A_e t_s = V``.  ``C_e`` is what a unit of plastic can add there (the envelope):
any printed ply of the bead model (:func:`~.beads.bead_ply_matrices`) is, per unit of fill, a
mixture of four local matrices -- fused (the card's ``Q``) or unfused (``E1`` along the bead, a
trace of ``E2``, the card's in-plane shear as its largest bending shear), each with a transfer
efficiency of 1 or 0 -- turned to its bead angle.  The matrix is affine in the fused fraction, the
transfer efficiency and the bending shear, so every bead the model can see lies in the convex hull
of those extremes at every angle; its orientation averaging is a mixture of angles, in that hull
too.  An effective fill over 1 (the model's clip of overlapping samples at 1.25) is not counted:
plastic cannot hold more than its element.

The bound.  The compliance ``c(D) = f . K(D)^-1 f`` (the model's, N mm) is convex in the element
matrices, and ``dc = -sum_e int eps . dD_e eps dV`` (``eps`` the strain of ``D``).  So for every
design ``D*`` in the envelope, ``c(D*) >= c(D) - max_{D* in envelope} sum_e M_e : (D*_e - D_e)``
with ``M_e = int eps eps^T dV``: a linear programme, solved exactly by giving the plastic to the
elements with the largest ``max_{candidate, angle} C : M_e / (A_e t)`` first (at most solid each).
This lower bound on any layout's compliance is an upper bound on its stiffness; it is tight at the
optimum.  :func:`optimum` improves the design by optimality criteria (fill and angle, the classical
variable-thickness sheet with fibre angles) and keeps the best design and the best bound: the
true optimum lies between them, and the gap is reported.

Angles are searched on a grid of :data:`ANGLES` (a quarter degree).  The energy ``f`` is a
non-negative trigonometric polynomial in the angle with harmonics 2 and 4, whose coefficients are
at most its mean (a non-negative function's Fourier coefficients are), so ``|f''| <= 20 max f`` and
the grid misses the maximum by at most ``10 (pi / 1440)**2`` (4.8e-5) of it: the bound takes every
grid maximum :data:`GRID_MISS` larger, so it stays a bound.

:func:`layout_bound` reads the two files it needs: the slicer's sparse file and the same part sliced at
0 % (walls and skins, the same settings otherwise), both on the model's mesh.  ``benchmarks/
bench_sparse_bound.py`` prints it for the parts of issue 15.

Assumption: walls and skins keep the stiffness they have without the sparse plastic (the 0 % file's
bead states); in the model a wall's beads can fuse a little more with infill beside them.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np
from loadpath._typing import Floats
from loadpath.density import MAX_PITCH_MM
from loadpath.errors import LoadpathError, SolverError
from loadpath.fea.assembly import cell_dofs, gradients, strain_matrix
from loadpath.fea.elements import triangle_rule
from loadpath.fea.orthotropic import PrintedMaterial, rotation_voigt
from loadpath.loadcase.model import LoadCase
from loadpath.loadcase.resolve import ResolvedBody, resolve
from loadpath.mesh.data import MeshData
from loadpath.stiffness.beads import UNFUSED_E2
from loadpath.stiffness.predict import solve_printed

__all__ = [
    "ANGLES",
    "GRID_MISS",
    "Optimum",
    "LayoutBound",
    "envelope",
    "strain_moments",
    "optimum",
    "layout_bound",
]

ANGLES = 720
"""Bead angles searched per element, evenly over 180 degrees."""

GRID_MISS = 5e-5
"""Most a grid maximum of the energy over the angles can fall short of the true one, relative."""


@dataclass(frozen=True)
class Optimum:
    """The best layout found and the certified bound.

    Attributes
    ----------
    compliance : float, N mm
        The best design's compliance (a layout in the envelope: an upper bound on the optimum's).
    lower_bound : float, N mm
        No layout of the plastic in the envelope has a lower compliance (module docstring).
    fill : (m,) float
        The best design's fill per element, 0-1.
    angle : (m,) float, rad
        Its bead angle per element.
    history : list of (float, float)
        ``(compliance, bound)`` of every iterate, N mm.
    residual : float
        Relative residual of the best design's solve.
    info : dict
    """

    compliance: float
    lower_bound: float
    fill: Floats = field(repr=False)
    angle: Floats = field(repr=False)
    history: list[tuple[float, float]] = field(default_factory=list, repr=False)
    residual: float = 0.0
    info: dict = field(default_factory=dict, repr=False)

    @property
    def gap(self) -> float:
        """``(compliance - lower_bound) / compliance``: how far the best design may be from the optimum."""
        return (self.compliance - self.lower_bound) / self.compliance


def envelope(material: PrintedMaterial) -> np.ndarray:
    """The four local (bead-axes) plane-stress matrices whose hull holds any bead per unit fill,
    ``(4, 3, 3)`` MPa.

    Fused (the card's ``Q``) and unfused (``E1``, a trace of ``E2``, the card's ``G12``), each with
    full transfer and with none (the along-bead coupling terms gone, ``E1`` along the bead kept).
    """
    Q = material.local(2)
    U = np.zeros((3, 3))
    U[0, 0] = material.E1
    U[1, 1] = UNFUSED_E2 * Q[1, 1]  # the bead model's own across-bead trace
    U[2, 2] = Q[2, 2]
    out = []
    for C in (Q, U):
        out.append(C)
        cut = C.copy()
        cut[0, 1:] = cut[1:, 0] = 0.0
        out.append(cut)
    return np.stack(out)


def strain_moments(mesh: MeshData, u: np.ndarray) -> np.ndarray:
    """``int eps eps^T dV`` per element, ``(m, 3, 3)`` mm³ (2D plate: times its thickness).

    ``compliance = sum_e D_e : M_e`` for the matrices ``D`` that gave ``u``.
    """
    if mesh.dim != 2:
        raise SolverError("the layout bound is made for in-plane (2D) parts only")
    xi, w = triangle_rule(2) if mesh.is_quadratic else triangle_rule(1)
    ue = np.asarray(u, dtype=float).ravel()[cell_dofs(mesh)]
    out = np.zeros((len(mesh.cells), 3, 3))
    step = 40000
    for s in range(0, len(mesh.cells), step):
        sl = slice(s, s + step)
        g = gradients(mesh, xi, sl)
        eps = np.einsum("mqvn,mn->mqv", strain_matrix(g.dN), ue[sl])
        out[sl] = mesh.thickness * np.einsum("mqv,mqw,mq,q->mvw", eps, eps, g.detJ, w)
    return out


def _best(M: np.ndarray, local: np.ndarray) -> tuple[Floats, Floats, np.ndarray]:
    """Per element the largest ``C : M`` over the candidates and angles: value ``(m,)`` N mm, angle
    ``(m,)`` rad and the winning global matrix ``(m, 3, 3)`` MPa."""
    theta = np.arange(ANGLES) * (np.pi / ANGLES)
    R = rotation_voigt(theta, 2)  # (a, 3, 3): C_global = R C R^T, so C_global : M = C : (R^T M R)
    m = len(M)
    best = np.full(m, -np.inf)
    at = np.zeros(m)
    which = np.zeros(m, dtype=np.int64)
    for a0 in range(0, ANGLES, 90):
        Rs = R[a0 : a0 + 90]
        Ml = np.einsum("aij,mik,akl->amjl", Rs, M, Rs)  # (a, m, 3, 3) in bead axes
        vals = np.einsum("cjl,amjl->cam", local, Ml)  # (candidate, a, m)
        flat = vals.reshape(-1, m)
        k = np.argmax(flat, axis=0)
        v = flat[k, np.arange(m)]
        better = v > best
        best[better] = v[better]
        c, a = np.divmod(k, len(Rs))
        at[better] = theta[a0 + a[better]]
        which[better] = c[better]
    Rb = rotation_voigt(at, 2)
    C = Rb @ local[which] @ np.swapaxes(Rb, 1, 2)
    return best, at, C


def _spread(weight: Floats, cap: Floats, volume: float, least: Floats | float = 0.0) -> Floats:
    """The most ``sum weight_e v_e`` with ``least_e <= v_e <= cap_e`` and ``sum v_e = volume``: each
    element its least, the rest to the elements of largest weight first (the linear programme's
    solution)."""
    base = np.broadcast_to(np.asarray(least, dtype=float), cap.shape).copy()
    room = cap - base
    rest = volume - float(base.sum())
    order = np.argsort(-weight, kind="stable")
    filled = np.cumsum(room[order])
    v = base
    full = filled <= rest
    v[order[full]] += room[order[full]]
    k = int(np.count_nonzero(full))
    if k < len(order):
        v[order[k]] += max(0.0, rest - (filled[k - 1] if k > 0 else 0.0))
    return v


def optimum(
    rb: ResolvedBody,
    mesh: MeshData,
    fixed: np.ndarray,
    material: PrintedMaterial,
    volume: float,
    share: float,
    iterations: int = 80,
    tol: float = 0.002,
    move: float = 0.2,
    floor: float = 0.0,
    room: Floats | None = None,
) -> Optimum:
    """The stiffest layout of ``volume`` of plastic over ``fixed`` walls and skins, and the bound.

    Parameters
    ----------
    rb : ResolvedBody
        The load case on the body (2D).
    mesh : MeshData
        The model's mesh (:func:`~.model.body_mesh`).
    fixed : (m, 3, 3) float, MPa
        Stack-mean stiffness of what stays (the part sliced at 0 %: walls and skins).
    material : PrintedMaterial
        The card's elastic ply.
    volume : float, mm³
        Plastic to lay (the slicer's sparse infill).
    share : float
        Share of the plate's thickness in the layers that hold it, ``t_s / t``.
    iterations : int
        Most optimality-criteria steps.
    tol : float
        Stop once the best design is within this share of the bound.
    move : float
        Largest change of an element's fill per step.
    floor : float
        Least fill of every element (0-1): the densest gap a top skin can bridge, say.  The bound then
        holds for the layouts that keep it.
    room : (m,) float, optional
        Share of each element's sparse layers free for the plastic, 0-1 (what the walls leave);
        default all of it.

    Returns
    -------
    Optimum

    Raises
    ------
    SolverError
        A failed solve; a volume the layers cannot hold.
    """
    area = np.abs(mesh.measures)
    t = mesh.thickness
    free = np.ones(len(area)) if room is None else np.clip(np.asarray(room, dtype=float), 0.0, 1.0)
    cap = area * t * share * free  # the most plastic each element's sparse layers hold, mm³
    if not (0 < share <= 1) or not (floor * cap.sum() <= volume <= cap.sum()) or volume <= 0:
        raise SolverError(
            f"{volume:.1f} mm³ does not fit the sparse layers ({floor * cap.sum():.1f}-{cap.sum():.1f} mm³)"
        )
    local = envelope(material)
    rho = np.full(len(area), volume / cap.sum()) * (free > 0)
    an, c, _, _, _ = solve_printed(rb, mesh, fixed)
    _, angle, C = _best(strain_moments(mesh, an.result.u), local)
    best_c, best = np.inf, (rho, angle, 0.0)
    bound = -np.inf
    history: list[tuple[float, float]] = []
    least = max(floor, 1e-3)  # the design's own floor (a fill of 0 would never come back)
    for _ in range(max(1, iterations)):
        D = fixed + share * (rho * free)[:, None, None] * C
        an, c, _, _, _ = solve_printed(rb, mesh, D)
        M = strain_moments(mesh, an.result.u)
        gain, angle_new, C_new = _best(M, local)  # N mm per unit fill of the whole thickness
        now = share * rho * free * np.einsum("mij,mij->m", C, M)
        most = share * gain
        # the linear programme over the envelope, per mm³ of plastic: share * gain / (A t share)
        most_e = gain * (1.0 + GRID_MISS) / (area * t)  # per mm³, never below the true maximum
        lp = float(np.sum(_spread(most_e, cap, volume, floor * cap) * most_e))
        bound = max(bound, c - (lp - float(now.sum())))
        history.append((c, bound))
        if c < best_c:
            best_c, best = c, (rho.copy(), angle.copy(), float(an.result.residual))
        if (best_c - bound) <= tol * best_c:
            break
        # optimality criteria: fill where the energy per plastic is high, at its best angle
        eff = np.maximum(most / (area * t * share), 0.0)
        lo, hi = 1e-12, float(eff.max()) * 10 + 1e-12
        low, high = np.maximum(least, rho - move), np.minimum(1.0, rho + move)
        for _ in range(80):
            lam = np.sqrt(lo * hi)
            if float(np.sum(np.clip(rho * np.sqrt(eff / lam), low, high) * cap)) > volume:
                lo = lam
            else:
                hi = lam
        rho = np.clip(rho * np.sqrt(eff / hi), low, high)
        rho *= volume / float(np.sum(rho * cap))  # the bisection's last step, exact on the volume
        rho = np.minimum(rho, 1.0)
        angle, C = angle_new, C_new
    f, a, res = best
    return Optimum(best_c, bound, f, a, history, res, {"iterations": len(history), "elements": len(area)})


@dataclass(frozen=True)
class LayoutBound:
    """What any layout of a sparse file's plastic can reach in the model (:func:`layout_bound`).

    Attributes
    ----------
    bound : float
        No layout of the plastic is stiffer than this many times the sparse file (compliance ratio).
    best : float
        The best layout found, as many times the sparse file (``bound`` and ``best`` bracket the optimum).
    volume : float, mm³
        The sparse plastic: the sparse file's deposited volume less the 0 % file's.
    share : float
        Share of the part's thickness in the layers with sparse infill.
    floor : float
        Least fill kept everywhere in those layers.
    optimum : Optimum
    """

    bound: float
    best: float
    volume: float
    share: float
    floor: float
    optimum: Optimum = field(repr=False)


def layout_bound(
    sparse: str | os.PathLike[str],
    bare: str | os.PathLike[str],
    loadcase: LoadCase,
    floor: float | None = None,
    max_pitch: float = MAX_PITCH_MM,
    iterations: int = 40,
    tol: float = 0.005,
) -> LayoutBound:
    """The stiffest layout of ``sparse``'s sparse plastic in the model, over the part sliced at 0 %.

    Parameters
    ----------
    sparse, bare : path
        The slicer's file and the same part sliced with no sparse infill (walls and skins as in
        ``sparse``).  One body, in-plane (2D) load case.
    loadcase : LoadCase
    floor : float, optional
        Least fill of the sparse layers; default the sparse beads' median width over ``max_pitch``
        (a top skin bridges at most that far, :data:`loadpath.density.MAX_PITCH_MM`).
    max_pitch : float, mm
    iterations, tol : see :func:`optimum`.

    Raises
    ------
    LoadpathError
        Files of different parts, several bodies, a 3D case, no sparse infill.
    """
    from loadpath import gcode, geometry
    from loadpath.gcode.flavors import Role
    from loadpath.stiffness.deposits import from_program
    from loadpath.stiffness.model import body_mesh, file_card
    from loadpath.stiffness.predict import predict

    program, other = gcode.read(sparse), gcode.read(bare)
    m = program.moves
    mine = (m["role"] == int(Role.SPARSE_INFILL)) & m["extrude"]
    if not mine.any():
        raise LoadpathError(f"{sparse}: no sparse infill to lay out; give the slicer's sparse file")
    geo = geometry.layer_geometry(program, check=False, outlines_only=True)
    bodies = resolve(loadcase, geo.bodies())
    if len(bodies) != 1 or bodies[0].analysis != "2d":
        raise LoadpathError(
            "the layout bound takes one body in an in-plane load case; name it with object = in the case"
        )
    rb = bodies[0]
    options, _, _ = file_card(program.config, loadcase)
    mesh = body_mesh(rb, options)
    # both files on the sparse file's mesh (their outlines may differ by a rounding), so they differ
    # only by their beads
    geo_b = geometry.layer_geometry(other, check=False, outlines_only=True)
    outline = rb.body.slabs[0].outline
    other_bodies = resolve(loadcase, geo_b.bodies())
    bare_outline = other_bodies[0].body.slabs[0].outline if len(other_bodies) == 1 else None
    if bare_outline is None or outline.symmetric_difference(bare_outline).area > 0.01 * outline.area:
        raise LoadpathError(f"{bare} is not the same part as {sparse}; slice the same STL at 0 % infill")
    beads = from_program(program, geo.object(rb.name).code, geo.filament_diameter)
    ps = predict(rb, beads, options, mesh)
    obj_b = geo_b.object(rb.name)
    pb = predict(rb, from_program(other, obj_b.code, geo_b.filament_diameter), options, mesh)
    layers = np.unique(m["layer"][mine])
    share = float(sum(program.layers[int(k)].height for k in layers)) / ps.mesh.thickness
    if floor is None:  # the sparse beads' flow width (from their plastic: Cura writes no widths)
        w = beads.flow_width[beads.role == int(Role.SPARSE_INFILL)]
        w = w[np.isfinite(w) & (w > 0)]
        if len(w) == 0:
            raise LoadpathError(f"{sparse}: its sparse beads have no width; give floor (a fill, 0-1)")
        floor = float(np.median(w)) / max_pitch
    walls = np.clip((pb.fill - (1.0 - share)) / share, 0.0, 1.0)  # what the walls fill of those layers
    volume = ps.volume - pb.volume
    o = optimum(
        rb, ps.mesh, pb.D, options.material, volume, share, iterations, tol, floor=floor, room=1.0 - walls
    )
    return LayoutBound(ps.compliance / o.lower_bound, ps.compliance / o.compliance, volume, share, floor, o)
