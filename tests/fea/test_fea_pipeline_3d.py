"""End to end in 3D: PrusaSlicer's G-code of the twisted tower, `loadpath run` with its default mesh.

The tower (tests/slicing.py) changes its outline every layer, so the load case is solved in 3D. This
is the run that used to mesh 370 000 tetrahedra and never finish; now its default mesh keeps within
the element budget, the solve is checked, and every replaced layer gets a field defined over all of
its infill.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fea_cases import TOWER_CASE
from loadpath import gcode
from loadpath.mesh import DEFAULT_MAX_TETS
from loadpath.plugin.job import JobRequest, run_job
from loadpath.tolerances import TOL


@pytest.mark.slow
def test_tower_runs_end_to_end_in_3d(prusa_tower, tmp_path):
    case = tmp_path / "tower.toml"
    case.write_text(TOWER_CASE, encoding="utf-8")
    out = tmp_path / "tower.loadpath.gcode"
    res = run_job(JobRequest(Path(prusa_tower), case, output=out, cli={"engine": "streamlines", "jobs": 1}))
    assert res.error is None and res.written and res.changed
    pipe = res.pipeline
    (an,) = pipe.analyses.values()
    assert an.analysis == "3d" and len(an.resolved.layers.slabs) >= 100
    assert len(an.mesh.cells) <= DEFAULT_MAX_TETS
    assert an.result.residual <= TOL.fea_residual and an.result.status.startswith("converged")

    # every replaced layer: the field is defined on all the new paths (the mesh covers the layer) ...
    strength = {}
    for job in pipe.jobs:
        for unit in job.units:
            field = an.field(unit.z_mid)
            pts = np.concatenate([p.points for p in job.paths.paths])
            t = field.tensor(pts)
            assert np.isfinite(t).all(axis=1).mean() > 0.99, f"layer {unit.layer}: field undefined on paths"
            strength[unit.z_mid] = float(np.nanmedian(field.sample(pts).magnitude))
    # ... and it is a 3D field, cut per layer: the layers by the clamp and by the pushed top face
    # (the replaced solid layers of this print) carry different in-plane stresses
    zs = sorted(strength)
    assert len(zs) >= 2 and zs[-1] - zs[0] > 10.0
    assert abs(strength[zs[-1]] - strength[zs[0]]) > 0.2 * max(strength[zs[0]], strength[zs[-1]])

    # the output is a valid program of the same dialect
    program = gcode.read(out)
    assert program.dialect == gcode.read(prusa_tower).dialect
