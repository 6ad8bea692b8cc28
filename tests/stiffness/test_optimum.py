"""The model's stiffest layout of a sparse plastic and the bound no layout beats (stiffness.optimum)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath import metrics
from loadpath.errors import SolverError
from loadpath.fea.orthotropic import PLA_PRINTED, rotate
from loadpath.loadcase import Body, parse, resolve
from loadpath.stiffness import (
    Deposits,
    StiffnessOptions,
    from_toolpaths,
    predict,
    solve_printed,
    stiffness_mesh,
)
from loadpath.stiffness.beads import bead_ply_matrices
from loadpath.stiffness.optimum import envelope, optimum, strain_moments
from loadpath.toolpath import Path

# a cantilever: clamped at x = 0, pulled down at its free end (bending, as issue 15's beams and brackets)
PLATE = shapely.box(0, 0, 60, 20).difference(shapely.Point(30, 10).buffer(3, quad_segs=32))
CASE = """
version = 1
[[supports]]
name = "clamp"
where = { x_max = 0.01 }
fix = ["x", "y", "z"]
[[loads]]
name = "tip"
where = { x_min = 59.99 }
force = [0.0, -200.0, 0.0]
"""
LAYERS, H, SKIN = 6, 0.25, (0, 5)
SPARSE_PITCH = 2.25  # a 20 % sparse infill of 0.45 mm beads


def _layer(k: int, angle: float, pitch: float, width: float = 0.45) -> Deposits:
    """Straight beads ``width`` wide, ``pitch`` apart (the sparse ones do not touch)."""
    laid = metrics.rectilinear(PLATE, pitch, angle).paths
    lines = [Path(p.points, np.full(len(p.points), width)) for p in laid]
    return from_toolpaths(lines, (k + 1) * H, H, k)


def _skins() -> list[Deposits]:
    return [_layer(k, 45.0 if k == 0 else -45.0, 0.45) for k in SKIN]


def _sparse(angles: list[float]) -> list[Deposits]:
    inner = [k for k in range(LAYERS) if k not in SKIN]
    return [_layer(k, angles[i % len(angles)], SPARSE_PITCH) for i, k in enumerate(inner)]


@pytest.fixture(scope="module")
def setup():
    body = Body.from_layers("plate", [(k * H, (k + 1) * H, PLATE) for k in range(LAYERS)])
    (rb,) = resolve(parse(CASE), [body])
    assert rb.analysis == "2d"
    mesh = stiffness_mesh(rb, 0.45)
    opts = StiffnessOptions(resolution=0.1)
    fixed = predict(rb, Deposits.concat(_skins()), opts, mesh)
    designs = {
        name: predict(rb, Deposits.concat(_skins() + _sparse(a)), opts, mesh)
        for name, a in {"0": [0.0], "0/90": [0.0, 90.0], "+-45": [45.0, -45.0], "90": [90.0]}.items()
    }
    share = (LAYERS - len(SKIN)) / LAYERS
    # the most plastic of the designs: one with less is no stiffer than the optimum with more
    volume = max(p.volume for p in designs.values()) - fixed.volume
    best = optimum(rb, mesh, fixed.D, opts.material, volume, share, iterations=25, tol=0.01)
    return rb, mesh, fixed, designs, share, volume, best


def test_the_envelope_holds_every_bead_the_model_can_see():
    """Per unit fill, any ply of the bead model stores no more energy at any strain than the best
    of the four envelope matrices at the same angle: what makes the bound hold for printed files."""
    rng = np.random.default_rng(7)
    Q = PLA_PRINTED.local(2)
    n = 4000
    fill = rng.uniform(0.02, 1.0, n)
    fused, transfer = rng.uniform(0, 1, n), rng.uniform(0, 1, n)
    fused[: n // 4], transfer[n // 4 : n // 2] = 1.0, 0.0  # the extremes too
    bending = rng.uniform(0, 2 * Q[2, 2], n)
    theta = rng.uniform(0, np.pi, n)
    C = rotate(bead_ply_matrices(Q, PLA_PRINTED.E1, fill, fused, transfer, bending), theta)
    C /= fill[:, None, None]
    eps = rng.normal(size=(n, 3, 2))
    M = np.einsum("niq,njq->nij", eps, eps)  # a sum of strain outer products, as over an element
    bead = np.einsum("nij,nij->n", C, M)
    hull = np.max([np.einsum("nij,nij->n", rotate(E, theta), M) for E in envelope(PLA_PRINTED)], axis=0)
    assert np.all(bead <= hull * (1 + 1e-12) + 1e-9)
    # and the envelope is not loose: the fused ply at full transfer is one of its corners
    fusedC = rotate(bead_ply_matrices(Q, PLA_PRINTED.E1, np.ones(n), np.ones(n), np.ones(n), bending), theta)
    corner = np.einsum("nij,nij->n", rotate(Q, theta), M)
    np.testing.assert_allclose(np.einsum("nij,nij->n", fusedC, M), corner)


def test_strain_moments_give_the_compliance(setup):
    rb, mesh, fixed, designs, *_ = setup
    p = designs["0/90"]
    an, c, *_ = solve_printed(rb, mesh, p.D)
    M = strain_moments(mesh, an.result.u)
    assert np.einsum("mij,mij->", p.D, M) == pytest.approx(c, rel=1e-9)


def test_no_layout_beats_the_bound_and_the_optimum_beats_straight_lines(setup):
    rb, mesh, fixed, designs, share, volume, best = setup
    assert best.lower_bound <= best.compliance
    assert best.gap < 0.01  # converged: the optimum is known within 1 %
    for name, p in designs.items():  # printed sparse files of the same plastic
        assert 0.95 * volume < p.volume - fixed.volume <= volume * (1 + 1e-12), name
        held = np.abs(mesh.measures).sum() * mesh.thickness * share  # what the sparse layers hold
        assert 0.15 < (p.volume - fixed.volume) / held < 0.25  # a 20 % sparse fill
        assert p.compliance >= best.lower_bound, name
        assert p.compliance > best.compliance, name
    # random layouts in the envelope, of the same plastic: none below the bound
    rng = np.random.default_rng(3)
    area = np.abs(mesh.measures)
    cap = area * mesh.thickness * share
    local = envelope(PLA_PRINTED)
    for _ in range(6):
        rho = rng.uniform(0, 1, len(area)) ** 3
        rho = np.minimum(rho * volume / np.sum(rho * cap), 1.0)
        C = rotate(local[rng.integers(0, 4, len(area))], rng.uniform(0, np.pi, len(area)))
        _, c, *_ = solve_printed(rb, mesh, fixed.D + share * rho[:, None, None] * C)
        assert c >= best.lower_bound
    # the history keeps the best design and the best bound
    assert best.compliance == min(c for c, _ in best.history)
    assert best.lower_bound == max(b for _, b in best.history)


def test_the_floor_and_the_walls_bind_the_layout(setup):
    rb, mesh, fixed, designs, share, volume, _ = setup
    area = np.abs(mesh.measures)
    room = np.where(np.arange(len(area)) % 5 == 0, 0.0, 1.0)  # a fifth of the elements taken (walls)
    o = optimum(rb, mesh, fixed.D, PLA_PRINTED, volume, share, iterations=10, tol=0.05, floor=0.1, room=room)
    cap = area * mesh.thickness * share * room
    assert np.all(o.fill[room > 0] >= 0.1 - 1e-12) and np.all(o.fill <= 1.0)
    assert np.sum(o.fill * cap) == pytest.approx(volume, rel=1e-6)
    assert o.lower_bound <= o.compliance


def test_plastic_the_layers_cannot_hold_is_refused(setup):
    rb, mesh, fixed, designs, share, volume, _ = setup
    cap = np.abs(mesh.measures).sum() * mesh.thickness * share
    with pytest.raises(SolverError, match="does not fit the sparse layers"):
        optimum(rb, mesh, fixed.D, PLA_PRINTED, 1.01 * cap, share)


def test_a_real_sparse_slice_is_far_below_what_its_plastic_allows(tmp_path):
    """PrusaSlicer 2.5's 20 % gyroid L-bracket (4 mm, 3 top / 3 bottom skins) against the same part at
    0 %: the model's best layout of its sparse plastic is stiffer than the slicer's, within its bound,
    and the loadpath run of the same file lies below the bound too."""
    import slicing
    from cases import BRACKET_PIN
    from loadpath import loadcase
    from loadpath.errors import LoadpathError
    from loadpath.plugin.job import JobRequest, run_job
    from loadpath.stiffness import compare_files
    from loadpath.stiffness.optimum import layout_bound

    sparse, case_path = slicing.gyroid_bracket(tmp_path, BRACKET_PIN)
    conf = slicing.GYROID_BRACKET
    assert conf["fill_density"] == "20%"
    bare = slicing.slice_prusa(
        tmp_path / "bracket.stl", tmp_path / "b0.gcode", **{**conf, "fill_density": "0%"}
    )
    case = loadcase.read(case_path)
    lb = layout_bound(sparse, bare, case, iterations=30, tol=0.01)
    assert 1.0 < lb.best <= lb.bound
    assert lb.optimum.gap < 0.01
    assert 0.04 < lb.floor < 0.07  # a 0.45 mm bead every 8 mm
    assert 0.3 < lb.share < 1.0
    out = tmp_path / "bracket.loadpath.gcode"
    cli = {"replace": ("solid", "sparse")}  # the test's own empty cache (conftest)
    res = run_job(JobRequest(sparse, case_path, output=out, cli=cli))
    assert res.error is None and res.written
    rows, _ = compare_files([str(sparse), str(out)], case)
    assert rows[1].relative_stiffness <= lb.bound
    with pytest.raises(LoadpathError, match="not the same part"):
        wider = slicing.bracket_mesh(thickness=4.0).apply_scale([1.03, 1.0, 1.0])
        other = slicing.write_stl(wider, tmp_path / "big.stl")
        layout_bound(sparse, slicing.slice_prusa(other, tmp_path / "big0.gcode", **conf), case)
