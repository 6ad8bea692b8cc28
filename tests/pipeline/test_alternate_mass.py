"""``principal = "alternate"`` with the default ``density = "auto"`` keeps the slicer's mass (issue 15).

The ``"stack"`` density of two alternating families moves plastic from each minor-stress layer to
the major-stress layer above; only the pair keeps the mass.  On a cantilever 80 x 12 x 2.4 mm
(``benchmarks/bench_printability.py``'s beam) sliced by CuraEngine 4.13 at 40 %, the minor layers'
level sets at the 8 mm widest pitch are too short to print, their blocks are kept as sliced with the
slicer's plastic, and the run laid +38 % of it; ``auto`` ranked that candidate first by its absolute
ratios.  The choice now puts the slicer's mass first (:mod:`loadpath.plugin.density_choice`).
"""

from __future__ import annotations

import pytest
import slicing
import trimesh
from cases import side_case
from loadpath import loadcase
from loadpath.plugin.density_choice import MASS_TOLERANCE
from loadpath.plugin.job import JobRequest, run_job
from loadpath.stiffness import compare_files


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    """The bench's cantilever sliced by CuraEngine at 40 %, and its load case (tip load, root clamped)."""
    folder = tmp_path_factory.mktemp("beam")
    stl = slicing.write_stl(slicing._at_origin(trimesh.creation.box(extents=(80.0, 12.0, 2.4))), folder / "beam.stl")
    src = slicing.slice_cura(
        stl, folder / "beam.gcode",
        **{**slicing.CURA_MIXED, "infill_sparse_density": "40", "infill_line_distance": "2.0"},
    )
    case = folder / "beam.toml"
    case.write_text(side_case((0.0, -200.0, 0.0), held_within=5.0, loaded_within=3.0), encoding="utf-8")
    return src, case


def _run(beam, out, **cli):
    src, case = beam
    res = run_job(JobRequest(src, case, output=out, cli={
        "engine": "levelset", "replace": ("sparse",), "principal": "alternate", "cache": False, **cli}))
    assert res.written and res.error is None, res.error
    slicer, ours = compare_files([str(src), str(out)], loadcase.read(case))[0]
    return res, ours.mass / slicer.mass - 1.0


@pytest.mark.slow
def test_alternate_sparse_keeps_the_slicers_mass_and_says_which_candidate_did_not(beam, tmp_path):
    res, off = _run(beam, tmp_path / "auto.gcode")
    assert res.pipeline.check is not None and not res.pipeline.check.problems
    assert [t[0] for t in res.density.tried] == ["energy", "stack"]
    # the candidate kept lays the slicer's plastic; one that did not is named, with its share
    assert res.density.criterion not in {c for c, _ in res.density.off_mass}
    for crit, share in res.density.off_mass:
        assert abs(share) > MASS_TOLERANCE
        assert f"{crit} laid {share:+.0%} of the slicer's plastic" in res.verdict.line()
    assert off == pytest.approx(0.0, abs=0.02)
    assert not [w for w in res.warnings if "not its mass" in w]


@pytest.mark.slow
def test_a_run_off_the_slicers_mass_says_so(beam, tmp_path):
    res, off = _run(beam, tmp_path / "stack.gcode", density="stack")
    said = [w for w in res.warnings if "of the slicer's plastic, not its mass" in w]
    # the forced "stack" pair is broken on this beam (its minor layers kept as sliced): the run says so
    assert off > 0.02 and len(said) == 1, (off, res.warnings)
