r"""Predicted stiffness of a printed part: the anisotropic FEA of its deposits, and the model's ceiling.

:func:`predict` meshes the body (or takes a mesh), turns the deposits into per-element material
(:mod:`loadpath.stiffness.fields`, :mod:`loadpath.fea.orthotropic`), solves the load case with the
in-house FEA (:func:`loadpath.fea.analyze` with one constitutive matrix per element) and reports the
compliance, the peak displacement, the mass and the strain energy density.

2D: a stack of plies
    For a body that is one prism under an in-plane load case (the load case's own 2D/3D decision,
    :func:`loadpath.loadcase.resolve`), the part is a plate in plane stress.  Every layer is a ply
    with its own per-element stiffness ``C_k`` (on the same triangles), and the plate's membrane
    stiffness is the thickness-weighted mean ``D = sum_k (h_k / t) C_k`` (classical lamination
    theory, ``A / t``).  **Assumption:** in-plane loads excite only the membrane response; the
    bending-extension coupling ``B`` of an unsymmetric stack (e.g. an odd number of +-45 plies) is
    neglected, i.e. the plate is held flat.  With ten or more plies alternating every layer ``B`` is
    a few per cent of ``A t`` and out-of-plane warping is small; the 3D analysis covers the rest.
3D
    Bodies with several prisms (or loads in z) are meshed with tetrahedra; each tetrahedron gets the
    material of the beads inside it (all its layers mixed, Voigt), rotated about z.

Compliance ``c = f . u`` (N mm, twice the strain energy; lower is stiffer).  Relative stiffness of
``B`` against ``A`` is ``c_A / c_B``; specific stiffness divides by the part's mass.

The model's ceiling (:func:`ceiling`)
    Every element fully filled (``v = 1``) with its filament along its local principal stress of
    largest magnitude, found by fixed-point iterations (solve, re-align every element to its new
    principal direction, solve again) from the isotropic solution; the stiffest iterate is kept.
    For a material stiffest along the filament this is the stationary design of compliance
    (Pedersen's optimality condition), so no path set of the same material should beat it in
    absolute stiffness; per mass it can, by leaving material out where it does little.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from loadpath._typing import Floats
from loadpath.errors import SolverError
from loadpath.fea.analysis import Analysis, analyze, build_mesh
from loadpath.fea.assembly import cell_dofs, gradients, strain_matrix
from loadpath.fea.boundary import load_vector
from loadpath.fea.elements import tetra_rule, triangle_rule
from loadpath.fea.orthotropic import BEADS, PLA_PRINTED, FillModel, PrintedMaterial, printed_matrices
from loadpath.fea.stress import cell_stress
from loadpath.loadcase.resolve import ResolvedBody
from loadpath.mesh.data import MeshData
from loadpath.mesh.sizing import DEFAULT_PITCH, MeshSize, default_mesh_size
from loadpath.stiffness.deposits import Deposits, Stack
from loadpath.stiffness.fields import DEFAULT_RESOLUTION, PlyFields, sample_deposits

__all__ = [
    "StiffnessOptions",
    "Prediction",
    "stiffness_mesh",
    "material_matrices",
    "floor_modes",
    "MODE_FLOOR",
    "predict",
    "ceiling",
    "solve_printed",
]

_CHUNK = 40000


@dataclass(frozen=True)
class StiffnessOptions:
    """How a printed part is modelled.

    Attributes
    ----------
    material : PrintedMaterial
        Default :data:`~loadpath.fea.orthotropic.PLA_PRINTED`.
    fill_model : FillModel
        ``BEADS`` (default: fusion, transfer and crossings measured from the beads,
        :mod:`loadpath.stiffness.beads`), ``LINEAR`` (every component scaled by the fill) or the
        thesis's spacing-dependent ``NMO``.
    resolution : float, mm
        Sampling step of the beads (:func:`~loadpath.stiffness.fields.sample_deposits`).
    mesh_size : MeshSize or float, optional
        Default :func:`stiffness_mesh`'s.
    pitch : float, mm
        Infill pitch the default mesh size derives from.
    """

    material: PrintedMaterial = PLA_PRINTED
    fill_model: FillModel = BEADS
    resolution: float = DEFAULT_RESOLUTION
    mesh_size: MeshSize | float | None = None
    pitch: float = DEFAULT_PITCH
    card: str | None = None
    """Material card to use by name (``pla``, ``petg``, ``abs``); None: the file's filament type
    (:func:`loadpath.stiffness.cards.card_for`).  Only :func:`~.compare.evaluate_file` reads it."""


@dataclass(frozen=True)
class Prediction:
    """Predicted response of one printed body.

    Attributes
    ----------
    name : str
        Body (object) name.
    compliance : float, N mm
        ``f . u``.
    strain_energy : float, N mm
        Sum over the elements of ``int 1/2 eps . D eps dV`` (``compliance / 2`` up to the solver residual).
    peak_displacement : float, mm
        Largest nodal displacement magnitude.
    mass : float, g
        Material inside the part outline (the ceiling: the fully dense part).
    volume : float, mm³
        The same as a volume.
    analysis : Analysis
        Mesh, displacements, residual, picked facets.
    D : (m, nv, nv) float, MPa
        Constitutive matrix per element.
    energy_density : (m,) float, MPa
        Strain energy per unit volume, per element.
    angle : (m,) float, rad
        Dominant filament direction per element, in [0, pi).
    strength : (m,) float
        How dominant (1: every ply one way; 0: cross-plied or empty).
    fill : (m,) float
        Thickness-weighted fill per element (uncapped).
    fields : PlyFields or None
        Per-ply material (None for the ceiling).
    info : dict
        Timings and diagnostics (JSON-serialisable).
    """

    name: str
    compliance: float
    strain_energy: float
    peak_displacement: float
    mass: float
    volume: float
    analysis: Analysis = field(repr=False)
    D: np.ndarray = field(repr=False)
    energy_density: Floats = field(repr=False)
    angle: Floats = field(repr=False)
    strength: Floats = field(repr=False)
    fill: Floats = field(repr=False)
    fields: PlyFields | None = field(default=None, repr=False)
    info: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def mesh(self) -> MeshData:
        """The mesh the prediction was made on."""
        return self.analysis.mesh

    @property
    def specific_compliance(self) -> float:
        """``compliance * mass``, N mm g: lower is stiffer per gram."""
        return self.compliance * self.mass


def stiffness_mesh(
    rb: ResolvedBody, pitch: float = DEFAULT_PITCH, size: MeshSize | float | None = None
) -> MeshData:
    """Mesh a body for the stiffness model.

    Default sizes: :func:`~loadpath.mesh.sizing.default_mesh_size` with the bulk size capped at
    ``8 pitch`` (the filament direction field must be resolved) and the finest size floored at
    ``2 pitch`` (an element must hold a few beads for its fill to mean something).
    """
    if size is None:
        largest = max(rb.body.slabs, key=lambda s: s.outline.area).outline
        d = default_mesh_size(largest, pitch)
        h = min(d.h, 8.0 * pitch)
        size = MeshSize(h, max(d.h_min, 2.0 * pitch), max(d.h_bc, 2.0 * pitch), d.grading)
    return build_mesh(rb, size, pitch)


MODE_FLOOR = 1e-3
"""Least stiffness of an element's softest mode, as a share of its stiffest (:func:`floor_modes`)."""


def floor_modes(D: np.ndarray, floor: float = MODE_FLOOR) -> np.ndarray:
    """Element matrices ``(m, nv, nv)`` MPa with every eigenvalue at least ``floor`` times the largest.

    A tetrahedron inside two layers of sparse infill holds beads of one direction that do not
    touch (the bead model's fusion 0): nearly free across them and in shear, its smallest
    eigenvalue 1e-6 of its largest.  A non-prismatic part at 40 % (the bench's taper, PrusaSlicer
    2.5 and CuraEngine 4.13) had 30 % of its elements so; the 3D solve's conjugate gradients
    diverged (relative residual 27-187) and ``loadpath compare`` failed on the slicer's own file.
    The layers bonded above and below hold such a layer; a thousandth of its stiffest mode is
    far below what they give it (a 40 % ply's crossings: 3e-3) and keeps the solve regular.
    Only elements below the floor change; a clearly negative eigenvalue (a broken matrix, which
    :func:`solve_printed` reports) is left as it is.
    """
    lam, vec = np.linalg.eigh(D)
    top = lam[:, -1:]
    low = (lam < floor * top) & (lam > -1e-9 * np.abs(top))
    rows = np.flatnonzero(low.any(axis=1))
    if len(rows) == 0:
        return D
    out = D.copy()
    lam_r = np.where(low[rows], floor * top[rows], lam[rows])
    out[rows] = np.einsum("mij,mj,mkj->mik", vec[rows], lam_r, vec[rows])
    return out


def material_matrices(fields: PlyFields, material: PrintedMaterial, model: FillModel, dim: int) -> np.ndarray:
    """Per-element stiffness of the stacked plies, ``(m, nv, nv)`` MPa (``sum_k w_k C_k``), the
    softest modes floored (:func:`floor_modes`)."""
    return floor_modes(_ply_matrices(fields, material, model, dim))


def _ply_matrices(fields: PlyFields, material: PrintedMaterial, model: FillModel, dim: int) -> np.ndarray:
    if model.kind == "beads":
        from loadpath.stiffness.beads import ply_sum

        return ply_sum(fields, material, dim)
    out = None
    fill = fields.effective_fill()
    for k in range(len(fields.layers)):
        C = printed_matrices(material, fill[k], fields.moments[k], model, dim)
        out = fields.weight[k] * C if out is None else out + fields.weight[k] * C
    assert out is not None
    return out


def _energy(mesh: MeshData, D: np.ndarray, u: np.ndarray) -> Floats:
    """Strain energy per element, ``(m,)`` N mm (exact quadrature for straight elements)."""
    xi, w = (
        (triangle_rule(2) if mesh.dim == 2 else tetra_rule(2))
        if mesh.is_quadratic
        else (triangle_rule(1) if mesh.dim == 2 else tetra_rule(1))
    )
    ue = np.asarray(u, dtype=float).ravel()[cell_dofs(mesh)]
    out = np.zeros(len(mesh.cells))
    t = mesh.thickness if mesh.dim == 2 else 1.0
    for s in range(0, len(mesh.cells), _CHUNK):
        sl = slice(s, s + _CHUNK)
        g = gradients(mesh, xi, sl)
        eps = np.einsum("mqvn,mn->mqv", strain_matrix(g.dN), ue[sl])
        sig = np.einsum("mvw,mqw->mqv", D[sl], eps)
        out[sl] = 0.5 * t * np.einsum("mqv,mqv,mq,q->m", eps, sig, g.detJ, w)
    return out


def solve_printed(
    rb: ResolvedBody,
    mesh: MeshData,
    D: np.ndarray,
    name: str | None = None,
) -> tuple[Analysis, float, float, Floats, float]:
    """Solve the load case with per-element matrices.

    Returns
    -------
    analysis : Analysis
    compliance : float, N mm
    strain_energy : float, N mm
    energy_density : (m,) float, MPa
    peak_displacement : float, mm

    Raises
    ------
    SolverError
        From the solve, or when ``f . u`` and twice the strain energy disagree (a broken matrix).
    """
    an = analyze(rb, mesh=mesh, D=D)
    u = an.result.u
    f = np.zeros(u.size)
    for load, _ in rb.loads:
        f += load_vector(mesh, an.facets, an.picked[load.name], load, rb.name)
    compliance = float(f @ u.ravel())
    energy = _energy(mesh, D, u)
    total = float(energy.sum())
    if not (compliance > 0 and abs(2.0 * total - compliance) <= 1e-6 * compliance + 1e-12):
        raise SolverError(
            f"object {name or rb.name!r}: compliance f.u = {compliance:.6g} N mm disagrees with twice "
            "the strain energy "
            f"{2 * total:.6g} N mm; the printed material matrices are not positive definite"
        )
    vol = np.abs(mesh.measures) * (mesh.thickness if mesh.dim == 2 else 1.0)
    peak = float(np.max(np.linalg.norm(u, axis=1)))
    return an, compliance, total, energy / vol, peak


def predict(
    rb: ResolvedBody,
    deposits: Deposits | Stack,
    options: StiffnessOptions | None = None,
    mesh: MeshData | None = None,
) -> Prediction:
    """Predict the stiffness of a printed body from its deposits.

    Parameters
    ----------
    rb : ResolvedBody
        The load case applied to the body (2D or 3D as resolved).
    deposits : Deposits or Stack
        The body's beads (:func:`~loadpath.stiffness.deposits.from_program`); a
        :class:`~loadpath.stiffness.deposits.Stack` is read part by part.
    options : StiffnessOptions
    mesh : MeshData, optional
        Default :func:`stiffness_mesh` (pass one to compare files on the very same mesh).

    Returns
    -------
    Prediction
    """
    t0 = time.perf_counter()
    options = StiffnessOptions() if options is None else options
    if mesh is None:
        mesh = stiffness_mesh(rb, options.pitch, options.mesh_size)
    t1 = time.perf_counter()
    fields = _sample(mesh, deposits, options)
    D = material_matrices(fields, options.material, options.fill_model, mesh.dim)
    t2 = time.perf_counter()
    an, c, energy, density, peak = solve_printed(rb, mesh, D)
    t3 = time.perf_counter()
    angle, strength = fields.direction()
    vol = fields.total_volume
    return Prediction(
        name=rb.name,
        compliance=c,
        strain_energy=energy,
        peak_displacement=peak,
        mass=vol * 1e-3 * options.material.density,
        volume=vol,
        analysis=an,
        D=D,
        energy_density=density,
        angle=angle,
        strength=strength,
        fill=fields.mean_fill(),
        fields=fields,
        info={
            "times": {"mesh": t1 - t0, "material": t2 - t1, "solve": t3 - t2},
            "elements": len(mesh.cells),
            "lost_volume": fields.lost,
            "residual": an.result.residual,
            "analysis": rb.analysis,
        },
    )


def _sample(mesh: MeshData, deposits: Deposits | Stack, options: StiffnessOptions) -> PlyFields:
    """Sample the deposits; the bead model first cuts them into pieces and measures their state (a few
    layers at a time: :func:`loadpath.stiffness.layered.sample_beads`)."""
    if options.fill_model.kind != "beads":
        whole = deposits.concat() if isinstance(deposits, Stack) else deposits
        return sample_deposits(mesh, whole, options.resolution)
    from loadpath.stiffness.layered import sample_beads

    return sample_beads(mesh, deposits, options.resolution, options.material.E1, options.material.G12)


def _principal_angle(mesh: MeshData, D: np.ndarray, u: np.ndarray) -> Floats:
    """Angle (rad) of the in-plane principal stress of largest magnitude at each element's centroid."""
    xi = np.full((1, mesh.dim), 1.0 / (mesh.dim + 1))
    s = cell_stress(mesh, D, u, xi)[:, 0]
    sxx, syy, sxy = (s[:, 0], s[:, 1], s[:, 2]) if mesh.dim == 2 else (s[:, 0], s[:, 1], s[:, 5])
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # direction of the algebraically largest one
    return np.where(sxx + syy >= 0.0, theta, theta + 0.5 * np.pi)


def ceiling(
    rb: ResolvedBody,
    options: StiffnessOptions | None = None,
    mesh: MeshData | None = None,
    iterations: int = 12,
    rtol: float = 1e-5,
) -> Prediction:
    """Compute the model's ceiling: every element fully filled along its principal stress (module docstring).

    Parameters
    ----------
    rb : ResolvedBody
    options : StiffnessOptions
        Material and fill model (the fill is 1 everywhere).
    mesh : MeshData, optional
    iterations : int
        Most re-alignments.
    rtol : float
        Stop when the compliance changes by less than this fraction.

    Returns
    -------
    Prediction
        ``info["history"]``: compliance of every iterate (N mm).
    """
    t0 = time.perf_counter()
    options = StiffnessOptions() if options is None else options
    if mesh is None:
        mesh = stiffness_mesh(rb, options.pitch, options.mesh_size)
    m = len(mesh.cells)
    ones = np.ones(m)
    iso = analyze(rb, mesh=mesh)
    angle = _principal_angle(mesh, iso.result.D, iso.result.u)
    best: tuple[float, Any] | None = None
    history = []
    prev = np.inf
    for _ in range(max(1, iterations)):
        mom = np.stack([np.cos(2 * angle), np.sin(2 * angle), np.cos(4 * angle), np.sin(4 * angle)], axis=1)
        D = printed_matrices(options.material, ones, mom, options.fill_model, mesh.dim)
        an, c, energy, density, peak = solve_printed(rb, mesh, D)
        history.append(c)
        if best is None or c < best[0]:
            best = (c, (an, energy, density, peak, D, angle))
        if abs(prev - c) <= rtol * c:
            break
        prev = c
        angle = _principal_angle(mesh, D, an.result.u)
    assert best is not None
    c, (an, energy, density, peak, D, angle) = best
    vol = float(np.sum(np.abs(mesh.measures)) * (mesh.thickness if mesh.dim == 2 else 1.0))
    return Prediction(
        name=rb.name,
        compliance=c,
        strain_energy=energy,
        peak_displacement=peak,
        mass=vol * 1e-3 * options.material.density,
        volume=vol,
        analysis=an,
        D=D,
        energy_density=density,
        angle=np.mod(angle, np.pi),
        strength=ones,
        fill=ones,
        fields=None,
        info={
            "history": history,
            "times": {"total": time.perf_counter() - t0},
            "elements": m,
            "residual": an.result.residual,
            "analysis": rb.analysis,
        },
    )
