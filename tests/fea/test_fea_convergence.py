"""Convergence against closed forms: cantilever tip deflection and the open-hole stress concentration."""

from __future__ import annotations

import loadpath.loadcase as lc
import numpy as np
import pytest
from fea_cases import KT_HANDBOOK, hole_segments, kt_at_hole, open_hole_body, open_hole_case, rate
from loadpath.fea import analyze, load_vector
from loadpath.mesh import MeshSize
from shapely.geometry import box

E, NU = 3500.0, 0.35
BEAM_L, BEAM_H, BEAM_T, P = 100.0, 10.0, 1.0, 1.0


def _tip_deflection(h: float) -> float:
    case = lc.parse(
        f"version = 1\n[material]\nyoungs_modulus = {E}\npoissons_ratio = {NU}\n"
        '[[supports]]\nname = "root"\nwhere = { side = "x_min", within = 0.0 }\nfix = ["x", "y"]\n'
        f'[[loads]]\nname = "tip"\nwhere = {{ side = "x_max", within = 0.0 }}\nforce = [0.0, {-P}, 0.0]\n',
        "cantilever.toml",
    )
    (rb,) = lc.resolve(case, [lc.Body.from_layers("beam", [(0.0, BEAM_T, box(0, 0, BEAM_L, BEAM_H))])])
    a = analyze(rb, size=MeshSize.uniform(h))
    f = load_vector(a.mesh, a.facets, a.picked["tip"], rb.loads[0][0]).reshape(-1, 2)
    # the work-conjugate tip deflection: load . displacement / P
    return float((f * a.result.u).sum() / P)


def test_cantilever_tip_deflection_converges_to_beam_theory():
    hs = np.array([5.0, 2.5, 1.25, 0.625])
    d = np.array([_tip_deflection(h) for h in hs])
    inertia = BEAM_T * BEAM_H**3 / 12
    euler = P * BEAM_L**3 / (3 * E * inertia)
    timoshenko = euler + P * BEAM_L / (5 / 6 * E / (2 * (1 + NU)) * BEAM_H * BEAM_T)
    # converged to Timoshenko's beam (shear included) within 0.5 %; Euler-Bernoulli alone is 0.8 % stiffer
    assert d[-1] == pytest.approx(timoshenko, rel=5e-3)
    assert abs(d[-1] / euler - 1) > 3e-3
    # monotone from below (a displacement method is too stiff) at the rate the clamped corner allows:
    # its singularity limits the energy error to about h^1.4 (quadratic elements would give h^4 without it)
    assert np.all(np.diff(d) > 0)
    r = rate(hs[:-1], np.abs(np.diff(d)))
    assert 1.2 < r < 2.5, f"observed rate {r:.2f}"


def test_open_hole_kt_converges_to_the_handbook_value():
    case = open_hole_case()
    hs = np.array([0.8, 0.4, 0.2, 0.1, 0.05])
    kt = []
    for h in hs:
        # the hole polygon is refined with the mesh, so the geometry converges to the circle too
        (rb,) = lc.resolve(case, [open_hole_body(hole_segments(h))])
        a = analyze(rb, size=MeshSize(3.0, h, 1.0))
        assert a.result.residual < 1e-10
        kt.append(kt_at_hole(a.mesh.points, a.result.stress))
    kt = np.array(kt)
    # within 5 % of the handbook value (Heywood 3.094, Peterson 3.087) on every mesh refined at the hole,
    # and within 1 % on the fine ones
    assert np.all(np.abs(kt / KT_HANDBOOK - 1) < 0.05), kt
    assert abs(kt[-1] / KT_HANDBOOK - 1) < 0.01, kt
    # converging: the error against the finest mesh falls at an observed rate of about h^2
    err = np.abs(kt[:-1] - kt[-1])
    r = rate(hs[:-1], err)
    assert r > 1.3, f"observed rate {r:.2f}, Kt {kt}"
