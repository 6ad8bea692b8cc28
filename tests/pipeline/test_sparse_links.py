"""Sparse infill's links keep the same share of a bead off their neighbours as solid infill's (issues 15, 19).

The linking's ``clearance`` is in pitches, and on solid infill the bead is the pitch.  Sparse beads
are far narrower than their spacing: in sparse pitches the clearance kept a link a whole bead or more
off the paths beside it, and most ends were left to a travel and a retraction.  The pipeline links
sparse units with :meth:`loadpath.engines.linking.LinkOptions.for_bead`.  On a real PrusaSlicer 2.5
L-bracket at 20 % gyroid (sparse infill replaced, the level sets), every sparse job's engine paths
linked both ways: far fewer runs at the bead's share, and the pipeline's own runs are as few.
"""

from __future__ import annotations

import pytest
import slicing
from cases import BRACKET_PIN
from loadpath import gcode, loadcase, pipeline
from loadpath.engines.linking import LinkOptions, link_paths
from loadpath.plugin import settings as settings_mod


def test_for_bead_scales_the_clearance_by_the_beads_share_of_the_pitch():
    o = LinkOptions()
    assert o.for_bead(0.45, 1.8).clearance == pytest.approx(o.clearance * 0.25)
    assert o.for_bead(0.45, 0.45) == o and o.for_bead(0.5, 0.4) == o  # solid: the bead is the pitch
    assert o.for_bead(0.45, 1.8).max_link == o.max_link  # nothing else changes


@pytest.mark.slow
def test_sparse_runs_link_at_the_beads_share(tmp_path, monkeypatch):
    src, case_path = slicing.gyroid_bracket(tmp_path, BRACKET_PIN)
    program = gcode.read(src)
    case = loadcase.read(case_path)
    splice = settings_mod.splice_options(settings_mod.resolve(program, toolpath=case.toolpath))
    calls, real = [], pipeline.link_paths

    def spy(paths, region, pitch, options, field=None, band=None):
        calls.append((pitch, options, band))
        return real(paths, region, pitch, options, field=field, band=band)

    monkeypatch.setattr(pipeline, "link_paths", spy)
    res = pipeline.run(program, case, pipeline.PipelineOptions(replace=("sparse",), workers=1), splice)
    assert res.check is not None and not res.check.problems
    sparse = [jr for jr in res.jobs if jr.job.unit.kind == "sparse"]
    assert sparse
    # sparse infill is linked without the engine's band and without insertions (LinkOptions.insert):
    # both took plastic from the lines at the slicer's mass (bench_sparse's shelf, issue 19)
    pitches = {jr.job.unit.pitch for jr in sparse}
    mine = [(o, b) for p, o, b in calls if p in pitches]
    assert mine and all(not o.insert and b is None for o, b in mine)
    wide = narrow = printed = 0
    for jr in sparse:
        u = jr.job.unit
        ps = jr.paths.paths
        wide += len(link_paths(ps, u.fill_region, u.pitch, LinkOptions())[0])
        bead = LinkOptions().for_bead(u.flow_width, u.pitch)
        narrow += len(link_paths(ps, u.fill_region, u.pitch, bead)[0])
        printed += len(jr.printed) if jr.printed else len(ps)
    assert narrow < 0.8 * wide, (narrow, wide)
    assert printed < 0.8 * wide, (printed, wide)
