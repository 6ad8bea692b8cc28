"""The toolpath options have one owner (``loadpath.options``): the settings, the load case's
``[toolpath]`` table and the pipeline's options agree with it."""

from __future__ import annotations

import dataclasses

import pytest
from loadpath import loadcase, options, pipeline
from loadpath.errors import LoadCaseError, SettingsError
from loadpath.plugin import settings as S

CASE = """version = 1
[toolpath]
{toolpath}
[[supports]]
where = {{ side = "x_min", within = 5.0 }}
fix = ["x", "y", "z"]
[[loads]]
where = {{ side = "x_max", within = 5.0 }}
force = [100.0, 0, 0]
"""


def test_settings_defaults_are_the_schemas():
    names = [f.name for f in dataclasses.fields(S.Settings) if f.name != "sources"]
    assert names == [f.name for f in S.SCHEMA]
    s = S.Settings()
    for f in S.SCHEMA:
        assert getattr(s, f.name) == f.default, f.name
    # the toolpath part of the schema is core's, field for field
    assert S.SCHEMA[: len(options.TOOLPATH_FIELDS)] == options.TOOLPATH_FIELDS


def test_pipeline_defaults_are_the_toolpath_options():
    p = pipeline.PipelineOptions()
    for name in ("engine", "pitch", "principal", "replace", "stagger"):
        assert getattr(p, name) == options.field(name).default, name
    with pytest.raises(SettingsError, match=r"PipelineOptions.replace: walls is not an infill kind"):
        pipeline.PipelineOptions(replace=("walls",))
    assert pipeline.PipelineOptions(pitch=0).pitch == 0  # 0: each unit's slicer pitch (user_pitch)
    assert options.user_pitch(0) is None and options.user_pitch(None) is None
    assert options.user_pitch(0.45) == 0.45


def test_the_toolpath_table_takes_the_schemas_keys_and_bounds():
    assert options.TABLE_KEYS == tuple(f.name for f in S.SCHEMA if f.toolpath)
    lc = loadcase.parse(CASE.format(toolpath='pitch = 0.5\nK = 2\nprincipal = "tensile"'))
    assert (lc.toolpath.pitch, lc.toolpath.K, lc.toolpath.principal) == (0.5, 2.0, "tensile")
    # the bounds are the schema's: the command line and the load case refuse the same values
    for key, value in (("pitch", 0.01), ("pitch", 60.0), ("K", 2000.0)):
        with pytest.raises(LoadCaseError, match=rf"toolpath\.{key} = {value:g}\b.*is outside"):
            loadcase.parse(CASE.format(toolpath=f"{key} = {value}"))
        with pytest.raises(SettingsError, match=rf"{key} \(command line\) = {value:g}\b.*is outside"):
            S.Settings().with_values({key: value}, "command line")
    # a setting without a unit reads without gaps, its help in brackets; an empty kind list is empty
    with pytest.raises(SettingsError, match=r"^K \(command line\) = -3 is outside 0\.\.1000 \(swarm: "):
        S.Settings().with_values({"K": -3}, "command line")
    with pytest.raises(SettingsError, match=r"^replace \(command line\) is empty; name at least one of solid"):
        S.Settings().with_values({"replace": ""}, "command line")
