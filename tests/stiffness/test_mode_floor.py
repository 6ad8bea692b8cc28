"""An element's softest mode is floored at a thousandth of its stiffest (``predict.floor_modes``).

Sparse infill alternates its direction layer by layer, and a tetrahedron inside two layers holds
beads of one direction that do not touch: nearly free across them.  On a non-prismatic part at 40 %
the 3D solve's conjugate gradients then did not converge and ``loadpath compare`` failed on the
slicer's own file (the bench's 80 mm taper, PrusaSlicer 2.5 and CuraEngine 4.13; the 40 mm one here,
PrusaSlicer 2.5: relative residual 1.1e-2 after 1000 iterations).
"""

from __future__ import annotations

import numpy as np
import slicing
from cases import TIP_BEND
from loadpath import loadcase
from loadpath.stiffness import evaluate_file
from loadpath.stiffness.predict import MODE_FLOOR, floor_modes


def _ratios(D: np.ndarray) -> np.ndarray:
    lam = np.linalg.eigvalsh(D)
    return lam[:, 0] / lam[:, -1]


def test_a_healthy_matrix_is_kept_and_a_one_way_ply_is_lifted_to_the_floor():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(5, 6, 6))
    healthy = np.einsum("mij,mkj->mik", a, a) + 6.0 * np.eye(6)
    assert np.array_equal(floor_modes(healthy), healthy)
    # unfused beads along x: stiff along them, nearly free across and in shear
    one_way = np.diag([1200.0, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6])[None]
    lifted = floor_modes(np.concatenate([healthy[:1], one_way]))
    assert np.array_equal(lifted[0], healthy[0])
    assert np.allclose(np.diag(lifted[1]), [1200.0] + [1200.0 * MODE_FLOOR] * 5)
    assert np.allclose(lifted[1], lifted[1].T)
    # a clearly negative mode is a broken matrix, for solve_printed to report: not hidden
    broken = np.diag([1200.0, -5.0, 1.0, 1.0, 1.0, 1.0])[None]
    assert np.array_equal(floor_modes(broken)[0, 1], broken[0, 1])
    assert np.isclose(np.linalg.eigvalsh(floor_modes(broken))[0, 0], -5.0)


def test_compare_solves_a_non_prismatic_part_at_40_percent(tmp_path):
    from conftest import require_tool

    require_tool("prusa-slicer")
    stl = slicing.write_stl(slicing.taper_mesh(40.0, 12.0, 3.6, 1.2), tmp_path / "taper.stl")
    settings = {**slicing.PRUSA_MIXED, "fill_density": "40%"}
    gpath = slicing.slice_prusa([stl], tmp_path / "p40.gcode", **settings)
    result = evaluate_file(gpath, loadcase.parse(TIP_BEND), metrics=False)
    (pred,) = result.predictions
    assert pred.analysis.result.residual <= 1e-8 and pred.analysis.result.mesh.dim == 3
    assert pred.compliance > 0 and np.isfinite(result.failures[0].failure_load)
    ratios = _ratios(pred.D)
    assert ratios.min() >= MODE_FLOOR * (1 - 1e-9)
    assert np.mean(np.isclose(ratios, MODE_FLOOR, rtol=1e-6)) > 0.05  # the floor holds many elements
