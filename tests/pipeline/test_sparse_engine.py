"""Which engine lays each kind (issues 15 and 19): the level sets unless the user names an engine.

``sparse_engine = "auto"`` (the default) lays sparse infill with the engine the user named with
``engine`` (command line, ``--set`` or the load case's ``[toolpath]``), else with the level sets
(:data:`loadpath.engines.SPARSE_DEFAULT`).  Solid infill with no engine named is tried with the
level sets first (:data:`loadpath.engines.SOLID_FIRST`) and laid by ``engine`` (default the swarm)
where they give way, a layer cut along a bending part's neutral axis.  A real PrusaSlicer 2.5
L-bracket at 20 % gyroid and the shipped open-hole specimen, run as a user runs them, show which
engine laid each distinct layer and what the verdict says.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import slicing
from cases import BRACKET_PIN, side_case
from choices import kept_layout
from loadpath import engines, gcode, loadcase
from loadpath.errors import LoadCaseError, SettingsError
from loadpath.loadcase import ToolpathOptions
from loadpath.plugin import settings as settings_mod
from loadpath.plugin.density_choice import SPREAD
from loadpath.plugin.job import JobRequest, run_job
from loadpath.plugin.solid_choice import THROUGH, WHOLE
from loadpath.plugin.solid_choice import describe as describe_solid

EXAMPLE = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def example():
    return gcode.read(EXAMPLE / "ohs.gcode")


def test_auto_is_the_level_sets_unless_an_engine_is_named(example):
    resolve = settings_mod.resolve
    assert resolve(example).engine_for_sparse() == engines.SPARSE_DEFAULT == "levelset"
    assert resolve(example).engine == engines.DEFAULT == "swarm"
    # solid infill: the level sets first, the swarm where they give way; an engine named lays it
    assert resolve(example).engine_first_on_solid() == (engines.SOLID_FIRST, {"give_way": True})
    assert engines.SOLID_FIRST == "levelset"
    assert resolve(example, cli={"engine": "swarm"}).engine_first_on_solid() is None
    assert resolve(example, toolpath=ToolpathOptions(engine="levelset")).engine_first_on_solid() is None
    assert resolve(example, cli={"engine": "streamlines"}).engine_for_sparse() == "streamlines"
    assert resolve(example, cli={"engine": "swarm"}).engine_for_sparse() == "swarm"  # named, even the default
    assert resolve(example, toolpath=ToolpathOptions(engine="swarm")).engine_for_sparse() == "swarm"
    named = resolve(example, toolpath=ToolpathOptions(engine="swarm", sparse_engine="streamlines"))
    assert named.engine_for_sparse() == "streamlines"
    # the command line wins over the load case, as for every option
    lc_sparse = ToolpathOptions(sparse_engine="streamlines")
    both = resolve(example, toolpath=lc_sparse, cli={"sparse_engine": "swarm"})
    assert both.engine_for_sparse() == "swarm" and both.source("sparse_engine") == "command line"


def test_a_bad_sparse_engine_is_one_line_naming_the_choices(example):
    with pytest.raises(SettingsError) as err:
        settings_mod.resolve(example, cli={"sparse_engine": "gyroid"})
    msg = str(err.value)
    assert "\n" not in msg and "sparse_engine" in msg and "auto" in msg and "levelset" in msg
    with pytest.raises(LoadCaseError) as err2:
        text = (EXAMPLE / "ohs.toml").read_text(encoding="utf-8")
        loadcase.parse(text + '\n[toolpath]\nsparse_engine = "x"\n')
    assert "sparse_engine" in str(err2.value) and "\n" not in str(err2.value)


def test_the_load_case_keeps_its_sparse_engine_written_and_read_back():
    text = (EXAMPLE / "ohs.toml").read_text(encoding="utf-8")
    table = '\n[toolpath]\nsparse_engine = "swarm"\ndensity = "stack"\nsparse_fill = 0.25\n'
    lc = loadcase.parse(text + table)
    assert lc.toolpath.sparse_engine == "swarm"
    assert loadcase.parse(loadcase.to_toml(lc)).toolpath == lc.toolpath  # density and fill kept too


@pytest.fixture(scope="module")
def bracket(tmp_path_factory):
    return slicing.gyroid_bracket(tmp_path_factory.mktemp("bracket_engines"), BRACKET_PIN)


def _engines_by_kind(res) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for jr in res.pipeline.jobs:
        out.setdefault(jr.job.unit.kind, set()).add(jr.engine)
    return out


@pytest.mark.slow
def test_sparse_laid_by_the_level_sets_solid_by_the_better_layout_and_the_verdict_says_so(bracket):
    src, case = bracket
    out = src.with_name("bracket.auto.gcode")
    cli = {"replace": ("solid", "sparse"), "density": "uniform"}  # the test's own empty cache (conftest)
    seen: list[tuple[str, int, int]] = []
    res = run_job(JobRequest(src, case, output=out, cli=cli, report=src.with_name("bracket-report")),
                  progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert res.written and res.error is None, res.error
    assert res.pipeline.check is not None and not res.pipeline.check.problems
    by_kind = _engines_by_kind(res)
    assert by_kind["sparse"] == {"levelset"}, by_kind
    assert seen.count(("judge", 1, 1)) == 3, seen  # the progress bar shows the three layouts predicted
    # solid infill is tried with the level sets first; the bracket bends, so their fit is cut along
    # its neutral axis and they give way to the swarm there: the run lays the part three ways (the
    # level sets ending on the cut, the level sets through it, the swarm where they gave way) and
    # keeps what the model of loadpath compare predicts better (solid_choice), and says so
    choice = res.solid
    assert choice is not None and choice.given_way == "swarm", choice
    assert [t[0] for t in choice.tried] == [WHOLE, THROUGH, "swarm"], choice
    k = kept_layout(choice)
    assert choice.whole == (k < 2) and choice.through == (k == 1), choice
    kept = choice.tried[k][1:]
    assert res.verdict.stiffness == pytest.approx(kept[0] - 1.0, abs=1e-3)
    assert res.verdict.failure_load == pytest.approx(kept[1] - 1.0, abs=1e-3)
    line = res.verdict.line()
    assert f"solid infill: {describe_solid(choice)}" in line, line
    assert line in out.read_text(encoding="utf-8").split("\n", 2)[1]  # the file's header says the same
    # the report says which layers the level sets gave way on, and why (none, where they were kept)
    metrics = json.loads((src.with_name("bracket-report") / "metrics.json").read_text(encoding="utf-8"))
    rows = [r for r in metrics["layers"] if r["kind"] == "solid"]
    assert rows and all((r["engine"] == "swarm") == (r["gave_way"] is not None) for r in rows), rows
    assert all(r["gave_way"]["engine"] == "levelset" for r in rows if r["gave_way"] is not None)
    if choice.whole:
        assert by_kind["solid"] == {"levelset"}, by_kind
        assert all(jr.paths.stats["give_way"] is False for jr in res.pipeline.jobs if jr.job.unit.kind == "solid")
        assert "with levelset;" in line, line
    else:
        assert "swarm" in by_kind["solid"], by_kind
        for jr in res.pipeline.jobs:  # the swarm only where the cut runs along the layer
            if jr.job.unit.kind != "solid":
                continue
            if jr.engine == "swarm":
                assert jr.paths.stats["gave_way"]["engine"] == "levelset", jr.paths.stats
                assert jr.paths.stats["gave_way"]["cut_mm"] > np.sqrt(jr.job.unit.fill_region.area)
            else:
                assert jr.engine == "levelset" and jr.paths.stats["give_way"] is False
        both = "levelset" in by_kind["solid"]  # a sliver of a layer the cut does not cross
        assert f"with swarm (solid), levelset ({'solid, ' if both else ''}sparse);" in line, line

    # an engine named by the user lays both kinds, and the verdict names it alone
    named = src.with_name("bracket.swarm.gcode")
    res2 = run_job(JobRequest(src, case, output=named, cli={**cli, "engine": "swarm"}))
    assert res2.written and res2.error is None, res2.error
    assert _engines_by_kind(res2) == {"solid": {"swarm"}, "sparse": {"swarm"}}
    assert "with swarm;" in res2.verdict.line()
    assert res2.solid is None and "solid infill:" not in res2.verdict.line()  # nothing gave way: no choice

    # tie_spread = 0: the model's rank alone, the same two layouts judged
    rank = src.with_name("bracket.rank.gcode")
    res3 = run_job(JobRequest(src, case, output=rank, cli={**cli, "tie_spread": 0.0}))
    assert res3.written and res3.error is None, res3.error
    c3 = res3.solid
    assert c3 is not None and c3.retractions == () and "a tie" not in res3.verdict.line()
    k3 = kept_layout(c3)
    assert c3.whole == (k3 < 2) and c3.through == (k3 == 1), c3


@pytest.mark.slow
def test_a_file_printed_solid_gets_no_density_choice_and_settles_its_solid_tie(sliced, tmp_path):
    """``--replace solid,sparse`` on a bending part printed at 100 %: no sparse infill, so no density
    candidate is laid beyond the first, and the solid layouts' tie is settled at the printer as
    without sparse (it went by rank alone: 713 retractions against 112 on a slender cantilever)."""
    src = sliced("prusa", "bracket", "solid")
    case = tmp_path / "bracket.toml"
    case.write_text(BRACKET_PIN, encoding="utf-8")
    res = run_job(JobRequest(src, case, output=tmp_path / "out.gcode",
                             cli={"replace": ("solid", "sparse"), "cache": False}))
    assert res.written and res.error is None, res.error
    assert res.density is None and "sparse density" not in res.verdict.line()
    choice = res.solid
    assert choice is not None and choice.spread == SPREAD > 0, choice
    k = kept_layout(choice)
    assert choice.whole == (k < 2) and choice.through == (k == 1), choice


@pytest.mark.slow
def test_a_part_in_tension_gets_the_level_sets_on_solid_infill_too(tmp_path):
    """The shipped example pulls an open-hole specimen: no neutral axis cuts its layers, so with no
    engine named its solid infill keeps the level sets, which link into zig-zags (issue 19)."""
    out = tmp_path / "ohs.loadpath.gcode"
    res = run_job(JobRequest(EXAMPLE / "ohs.gcode", EXAMPLE / "ohs.toml", output=out, cli={"cache": False}))
    assert res.written and res.error is None, res.error
    assert _engines_by_kind(res) == {"solid": {"levelset"}}
    assert all(jr.paths.stats["give_way"] is False for jr in res.pipeline.jobs)
    assert " with levelset;" in res.verdict.line()
    assert res.solid is None and "solid infill:" not in res.verdict.line()  # laid once: nothing to choose
    # named, the swarm lays it all, as before
    res2 = run_job(JobRequest(EXAMPLE / "ohs.gcode", EXAMPLE / "ohs.toml", output=tmp_path / "s.gcode",
                              cli={"cache": False, "engine": "swarm"}))
    assert _engines_by_kind(res2) == {"solid": {"swarm"}}
    ours, swarm = (r.verdict.printability["loadpath"]["retractions"] for r in (res, res2))
    assert ours < swarm, (res.verdict.line(), res2.verdict.line())


BEND_TAPER = side_case((0.0, -100.0, 0.0), held_within=4.0, loaded_within=3.0, load="tip")
"""A cantilever held within 4 mm of x_min, 100 N down (-y) within 3 mm of x_max."""


@pytest.mark.slow
def test_a_3d_part_printed_solid_keeps_the_level_sets_where_they_gave_way(tmp_path):
    """A tapered cantilever at PrusaSlicer 100 % is a 3D analysis, which the model does not judge on
    every run: bent, its level sets give way, and it keeps them on every solid layer unjudged (the
    verdict says so) instead of the swarm's fragments; fewer retractions than the swarm laid where
    they gave way."""
    from conftest import require_tool

    require_tool("prusa-slicer")
    stl = slicing.write_stl(slicing.taper_mesh(40.0, 12.0, 3.0, 1.0), tmp_path / "taper.stl")
    src = slicing.slice_prusa([stl], tmp_path / "taper.gcode", **slicing.PRUSA_SOLID)
    case = tmp_path / "taper.toml"
    case.write_text(BEND_TAPER, encoding="utf-8")
    # the test's own empty cache (conftest): the run computes all, and the swarm's run below reads
    # the analysis and the swarm's layers the give-way pass laid (a third of the time without it)
    res = run_job(JobRequest(src, case, output=tmp_path / "out.gcode"))
    assert res.written and res.error is None, res.error
    assert any(jr.paths.stats.get("give_way") is False for jr in res.pipeline.jobs)
    assert _engines_by_kind(res) == {"solid": {"levelset"}}
    assert res.solid is not None and not res.solid.judged and res.solid.whole
    said = "solid infill: level sets on every solid layer (not judged: a 3D part printed solid"
    assert said in res.verdict.line()
    swarm = run_job(JobRequest(src, case, output=tmp_path / "swarm.gcode", cli={"engine": "swarm"}))
    ours, theirs = (r.verdict.printability["loadpath"]["retractions"] for r in (res, swarm))
    assert ours < theirs, (res.verdict.line(), swarm.verdict.line())
