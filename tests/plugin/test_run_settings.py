"""Settings: one schema, rising precedence defaults < slicer < load case [toolpath] < command line."""

from __future__ import annotations

import argparse
import json

import pytest
from cases import GRIP_PULL
from loadpath import engines, gcode, loadcase
from loadpath.errors import SettingsError
from loadpath.plugin import settings as S

CASE = GRIP_PULL + """[toolpath]
engine = "streamlines"
pitch = 0.5
K = 9.0
principal = "alternate"
replace = ["solid", "sparse"]
"""


def test_precedence(sliced):
    program = gcode.read(sliced("prusa", "ohs", "mixed"))
    lc = loadcase.parse(CASE)
    s = S.resolve(program)
    assert (s.retract_length, s.retract_lift, s.travel_speed, s.wipe) == (0.8, 0.4, 180.0, True)
    assert s.source("retract_length") == "slicer config" and s.source("engine") == "default"
    assert s.max_volumetric_speed == 15.0  # filament_max_volumetric_speed, max_volumetric_speed is 0
    s = S.resolve(program, toolpath=lc.toolpath)
    assert (s.engine, s.pitch, s.K, s.principal, s.replace) == (
        "streamlines",
        0.5,
        9.0,
        "alternate",
        ("solid", "sparse"),
    )
    assert s.source("pitch") == "load case"
    s = S.resolve(
        program,
        toolpath=lc.toolpath,
        cli={"engine": "swarm", "pitch": "0.45", "retract_length": 1.2},
        env={"SLIC3R_RETRACT_LENGTH": "2", "SLIC3R_travel_speed": "150", "SLIC3R_PP_HOST": "File"},
    )
    assert (s.engine, s.pitch, s.K) == ("swarm", 0.45, 9.0)
    assert s.retract_length == 1.2 and s.source("retract_length") == "command line"
    assert s.travel_speed == 150.0 and s.source("travel_speed") == "SLIC3R_* environment"


def test_cura_without_settings_infers_from_moves(sliced):
    program = gcode.read(sliced("cura", "ohs", "mixed"))
    s = S.resolve(program)
    assert s.flow_model == "rectangle"
    assert s.travel_speed == 120.0 and s.retract_length == 0.8 and s.retract_speed == 25.0
    assert s.source("travel_speed") == "inferred from the G-code"


def test_cura_settings_json(tmp_path, sliced):
    program = gcode.read(sliced("cura", "ohs", "mixed"))
    js = tmp_path / "c.json"
    js.write_text(
        json.dumps(
            {
                "global": {
                    "speed_travel": 200,
                    "retraction_hop_enabled": True,
                    "retraction_hop": 0.3,
                    "retraction_combing": "noskin",
                    "material_flow": 95,
                },
                "extruders": [{"retraction_amount": 6.5, "material_diameter": 2.85}],
            }
        )
    )
    s = S.resolve(program, cura_settings=S.read_cura_settings(js))
    assert (s.travel_speed, s.retract_lift, s.retract_length, s.filament_diameter) == (200.0, 0.3, 6.5, 2.85)
    assert s.only_retract_when_crossing_perimeters and s.extrusion_multiplier == pytest.approx(0.95)
    assert s.source("retract_length") == "Cura settings"


def test_slic3r_env_is_case_insensitive():
    cfg = S.from_slic3r_env(
        {"SLIC3R_Retract_Length": "1.5", "SLIC3R_NOZZLE_DIAMETER": "0.6,0.4", "PATH": "/bin"}
    )
    vals = S.from_prusa_config(cfg)
    assert vals["retract_length"] == "1.5" and vals["nozzle_diameter"] == "0.6"


def test_cli_options_come_from_the_schema():
    parser = argparse.ArgumentParser()
    S.add_cli_options(parser)
    args = parser.parse_args(
        [
            "--engine",
            "streamlines",
            "--pitch",
            "0.5",
            "--K",
            "3",
            "--replace",
            "solid,top",
            "--set",
            "width_max=1.4",
            "--on-failure",
            "keep",
        ]
    )
    vals = S.cli_values(args)
    assert vals == {
        "engine": "streamlines",
        "pitch": "0.5",
        "K": "3",
        "replace": "solid,top",
        "on_failure": "keep",
        "width_max": "1.4",
    }
    s = S.Settings().with_values(vals, "command line")
    assert s.replace == ("solid", "top") and s.width_max == 1.4 and s.K == 3.0
    flags = {a.option_strings[0] for a in parser._actions if a.option_strings}
    assert {"--engine", "--pitch", "--K", "--replace", "--on-failure"} <= flags


def test_cli_help_states_what_not_setting_a_flag_does():
    parser = argparse.ArgumentParser()
    S.add_cli_options(parser)
    helps = {a.option_strings[0]: a.help for a in parser._actions if a.option_strings}
    # not set, the run lays the level sets (and the swarm where they give way), not the field's 'swarm'
    assert "not set: levelset" in helps["--engine"] and "(default" not in helps["--engine"]
    assert "default: the slicer's pitch" in helps["--pitch"] and "(default None)" not in helps["--pitch"]
    assert helps["--replace"].endswith("(default solid)")
    assert helps["--on-failure"].endswith("(default 'fail')")


@pytest.mark.parametrize(
    "values,match",
    [
        ({"engine": "magic"}, "engine"),
        ({"replace": "walls"}, "walls"),
        ({"pitch": "-0.4"}, "pitch"),
        ({"width_min": "abc"}, "width_min"),
        ({"bogus": 1}, "unknown"),
    ],
)
def test_bad_values_name_the_setting(values, match):
    with pytest.raises(SettingsError, match=match):
        S.Settings().with_values(values, "command line")


def test_cura_setting_definitions_from_the_schema():
    defs = S.cura_setting_definitions()
    assert defs["engine"]["type"] == "enum" and set(defs["engine"]["options"]) == set(engines.NAMES) == {"swarm", "streamlines", "levelset"}
    assert defs["pitch"]["unit"] == "mm" and defs["K"]["default_value"] == 5.0
    json.dumps(defs)  # what getSettingDataString needs


def test_a_mistyped_set_key_is_named_with_its_near_miss():
    with pytest.raises(SettingsError, match=r"unknown setting\(s\) widht_max .*did you mean width_max\?"):
        S.Settings().with_values({"widht_max": "1.4"}, "command line")


def test_an_unknown_set_key_fails_in_the_run_so_on_failure_keep_holds(tmp_path, sliced, capsys):
    """A typo in ``--set`` stopped a PrusaSlicer export hooked with ``--on-failure keep``: the key was
    refused while the command line was read, before the run that keeps the slicer's G-code, and the
    message did not say what became of the files."""
    from loadpath.plugin.cli import main

    src = sliced("prusa", "ohs", "mixed")
    case = tmp_path / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    out = tmp_path / "out.gcode"
    base = ["run", str(src), "--loadcase", str(case), "-o", str(out), "--set", "foo=1"]
    assert main([*base, "--on-failure", "keep"]) == 0
    err = capsys.readouterr().err
    assert "unknown setting(s) foo" in err and "is a copy of the slicer's G-code" in err
    assert out.read_bytes() == src.read_bytes()
    out.unlink()
    assert main(base) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown setting(s) foo" in err[0] and "was not written" in err[0]
    assert not out.exists()
