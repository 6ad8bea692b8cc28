"""First-ply failure also runs on a 3D (tetrahedral) prediction, and agrees with the 2D ply stack.

The thin plate of ``test_predict`` (0/90 lines pulled along x): in 3D every tetrahedron holds both
directions (one mixed ply), in 2D each layer is its own ply, so the failure loads differ by what the
mixing hides; both must be finite and of the same order, and both fail along the beads.
"""

from __future__ import annotations

import pytest
from loadpath.loadcase.resolve import resolve
from loadpath.stiffness import StiffnessOptions, predict
from loadpath.stiffness.cards import PLA_CARD
from loadpath.stiffness.strength import first_failure
from test_predict import CASE, body, lines, parse


def test_first_failure_in_3d_and_2d_of_a_thin_cross_plied_plate():
    (rb2,) = resolve(parse(CASE), [body()])
    (rb3,) = resolve(parse(CASE), [body()], analysis="3d")
    dep = lines([0.0, 90.0])
    opts = StiffnessOptions(resolution=0.1)
    f2 = first_failure(predict(rb2, dep, opts), PLA_CARD)
    f3 = first_failure(predict(rb3, dep, opts), PLA_CARD)
    assert 0 < f2.failure_load < float("inf") and 0 < f3.failure_load < float("inf")
    assert 0.3 < f3.failure_load / f2.failure_load < 3.0, (f2, f3)
    assert f2.ply >= 0 and f3.ply == -1 and len(f3.location) == 3
