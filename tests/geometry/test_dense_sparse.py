"""Dense sparse infill (70-99 %) is sparse infill: kept by the default replace set, not laid as solid."""

from __future__ import annotations

import pytest
from cases import GRIP_PULL
from loadpath import gcode, geometry
from loadpath.gcode.flavors import Role
from loadpath.plugin.job import JobRequest, run_job


def _kinds(path):
    geo = geometry.layer_geometry(gcode.read(path), check=False)
    return {
        b.kind for o in geo.objects for lg in o.layers[1:-1] for isl in lg.islands for b in isl.blocks
        if b.role == Role.SPARSE_INFILL
    }


@pytest.mark.parametrize(("slicer", "density", "kind"), [
    ("prusa", "70%", "sparse"), ("prusa", "95%", "solid"), ("cura", "70", "sparse"), ("cura", "100", "solid"),
])
def test_the_slicers_sparse_infill_is_solid_from_90_percent(sliced, slicer, density, kind):
    key = "fill_density" if slicer == "prusa" else "infill_sparse_density"
    extra = {} if slicer == "prusa" else {"infill_line_distance": f"{0.4 * 100 / float(density):.3f}"}
    assert _kinds(sliced(slicer, "ohs", "mixed", **{key: density}, **extra)) == {kind}


def test_seventy_percent_infill_is_left_to_the_sparse_setting(tmp_path, sliced):
    """At 70 % the blocks were taken as solid and laid at the solid pitch: 112-122 % of the slicer's
    plastic, every one kept as sliced with a warning that the engine covered too much, under the
    default that replaces internal solid infill only."""
    src = sliced("prusa", "ohs", "mixed", fill_density="70%")
    case = tmp_path / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    res = run_job(JobRequest(src, case, output=tmp_path / "out.gcode", cli={"cache": False}))
    assert res.error is None
    assert not any("covered too much" in w for w in res.warnings), res.warnings
    assert "sparse" not in res.verdict.kinds
    sparse = {"cache": False, "replace": ("sparse",)}
    res = run_job(JobRequest(src, case, output=tmp_path / "out2.gcode", cli=sparse))
    assert res.error is None and "sparse" in res.verdict.kinds, res.warnings
