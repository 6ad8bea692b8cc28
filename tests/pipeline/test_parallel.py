"""Per-layer work in worker processes gives the same file as in one process (deterministic)."""

from __future__ import annotations

from fixtures import without_verdict
from pipeline_helpers import run, write_case


def test_workers_do_not_change_the_output(sliced, tmp_path):
    gpath = sliced("prusa", "ohs", "mixed")
    case = write_case(tmp_path)
    _, one, _ = run(
        gpath, case, tmp_path / "one.gcode", replace="sparse,solid", principal="alternate", jobs=1,
        cache=False,  # each run makes its own paths (the second would load the first's from the cache)
    )
    _, two, _ = run(
        gpath, case, tmp_path / "two.gcode", replace="sparse,solid", principal="alternate", jobs=2,
        cache=False,  # each run makes its own paths (the second would load the first's from the cache)
    )
    assert len(one.pipeline.jobs) >= 3  # several engine runs, so the pool is used
    a, b = (tmp_path / "one.gcode").read_bytes(), (tmp_path / "two.gcode").read_bytes()
    assert without_verdict(a) == without_verdict(b) and b"\n; loadpath: " in a
