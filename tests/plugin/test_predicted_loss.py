"""The warning a run gives when the mechanics model predicts its infill worse than the slicer's."""

from __future__ import annotations

import pytest
from loadpath.plugin.job import predicted_loss
from loadpath.stiffness.change import StiffnessChange
from loadpath.verdict import Verdict


@pytest.mark.parametrize(("k", "f", "what"), [
    (-0.079, -0.174, "less stiff and weaker"),  # a gear held at its hub, pushed on a tooth (PrusaSlicer)
    (-0.015, -0.035, "less stiff"),  # the failure load within the model's 6 % round-off
    (0.004, -0.071, "weaker"),
    (-0.004, -0.059, ""),  # both within what the model resolves
    (-0.03, 0.08, ""),  # a loss of stiffness made up by a gain of strength beyond the spread
    (0.02, -0.10, ""),  # and the other way round
    (-0.02, None, "less stiff"),  # stiffness only
])
def test_a_loss_beyond_the_models_spread_is_a_warning(k, f, what):
    text = predicted_loss(StiffnessChange(k, k, f, f))
    if not what:
        assert text == ""
    else:
        assert text.startswith(f"the mechanics model predicts the new infill {what} than the slicer's (")
        assert f"stiffness {k:+.1%}" in text and "print the slicer's G-code instead" in text


def test_a_change_that_rounds_to_nothing_reads_plus_zero_not_minus_zero():
    """An L-bracket of the hardening sweep printed "stiffness -0.0%" (a loss of 0.04 %)."""
    text = predicted_loss(StiffnessChange(-0.0004, -0.0004, -0.075, -0.075))
    assert "stiffness +0.0%, failure load -7.5%" in text, text


def test_nothing_predicted_no_warning():
    assert predicted_loss(None) == ""


def test_the_verdict_line_reads_plus_zero_for_a_change_that_rounds_to_nothing():
    v = Verdict(
        "0", "2026-12-07T20:00Z", True, (2, 3), ("solid",), "levelset", -0.0004, -0.0004, -0.075, -0.075,
        "first-ply failure, PLA card",
    )
    line = v.line()
    assert "predicted stiffness +0.0 % absolute, +0.0 % at the same mass" in line, line
    assert "failure load -7.5 % absolute, -7.5 % at the same mass" in line, line
    assert "-0.0" not in line
