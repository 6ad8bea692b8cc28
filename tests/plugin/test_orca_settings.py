"""Machine settings from OrcaSlicer's and Bambu Studio's configuration block (their own option names).

The files are real slicer output committed under ``tests/data/published/`` (README there).  Each value
read from the configuration is also checked against what the file's own moves do.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from loadpath import gcode
from loadpath.errors import SettingsError
from loadpath.plugin import settings as S

PUBLISHED = Path(__file__).resolve().parents[1] / "data" / "published"
ORCA_P1S = PUBLISHED / "orcaslicer-2.3.1-bambu-p1s-cube20.gcode"
BAMBU_A1MINI = PUBLISHED / "bambustudio-02.04.00.70-a1mini-labels-arcs.gcode"


@pytest.fixture(scope="module")
def orca():
    return gcode.read(ORCA_P1S)


def _mode(values: np.ndarray) -> float:
    v, c = np.unique(np.round(values, 3), return_counts=True)
    return float(v[np.argmax(c)])


def test_orca_options_are_read(orca):
    # z_hop = 0.4, filament_flow_ratio = 0.98, print_flow_ratio = 1, retraction_length = 0.8,
    # retraction_speed = 30, deretraction_speed = 30, retraction_minimum_travel = 1,
    # reduce_infill_retraction = 1
    s = S.resolve(orca)
    assert s.retract_lift == pytest.approx(0.4)
    assert s.extrusion_multiplier == pytest.approx(0.98)
    assert (s.retract_length, s.retract_speed, s.deretract_speed) == (0.8, 30.0, 30.0)
    assert s.retract_before_travel == 1.0 and s.only_retract_when_crossing_perimeters
    assert s.wipe and s.retract_before_wipe == 0.0 and not s.use_firmware_retraction
    assert (s.travel_speed, s.max_volumetric_speed) == (500.0, 12.0)
    orca_named = ("retract_lift", "extrusion_multiplier", "retract_length", "retract_speed",
                  "deretract_speed")
    for name in orca_named:
        assert s.source(name) == "slicer config", name


def test_orca_options_agree_with_the_moves(orca):
    s = S.resolve(orca)
    m = orca.moves
    z = np.array([layer.z for layer in orca.layers])
    travel = m[m["travel"] & (m["layer"] >= 0)]
    hop = travel["z1"] - z[travel["layer"]]
    assert _mode(hop[hop > 0.01]) == pytest.approx(s.retract_lift)  # travels 0.4 mm above the layer
    held = orca.state.retracted
    assert _mode(held[held > 0]) == pytest.approx(s.retract_length)  # pull + wipe: 0.8 mm held back
    pulls = m[m["retract"] & (m["e"] < 0) & ~m["wipe"]]
    assert _mode(pulls["f"]) / 60.0 == pytest.approx(s.retract_speed)
    primes = m[m["unretract"] & (m["e"] > 0)]
    assert _mode(primes["f"]) / 60.0 == pytest.approx(s.deretract_speed)


def test_bambu_studio_options_are_read():
    program = gcode.read(BAMBU_A1MINI)
    vals = S.from_prusa_config(program.config)
    assert float(vals["retract_lift"]) == pytest.approx(0.4)  # z_hop = 0.4
    assert vals["extrusion_multiplier"] == pytest.approx(1.0)  # filament_flow_ratio = 1
    assert float(vals["retract_length"]) == pytest.approx(0.8)  # retraction_length = 0.8
    assert float(vals["deretract_speed"]) == pytest.approx(30.0)


def test_per_extruder_values_take_the_tool():
    cfg = {
        "z_hop": "0.4,0.2",
        "retraction_length": "0.8,1.5",
        "retraction_speed": "30,25",
        "deretraction_speed": "0,20",
        "filament_flow_ratio": "0.98,0.95",
        "print_flow_ratio": "1.02",
    }
    vals = S.from_prusa_config(cfg, tool=1)
    assert (vals["retract_lift"], vals["retract_length"], vals["retract_speed"], vals["deretract_speed"]) == (
        "0.2", "1.5", "25", "20")
    assert vals["extrusion_multiplier"] == pytest.approx(0.95 * 1.02)
    assert S.from_prusa_config(cfg, tool=0)["extrusion_multiplier"] == pytest.approx(0.98 * 1.02)


def test_prusaslicer_names_win():
    cfg = {"retract_lift": "0.6", "z_hop": "0.4", "extrusion_multiplier": "0.9",
           "filament_flow_ratio": "0.98"}
    vals = S.from_prusa_config(cfg)
    assert vals["retract_lift"] == "0.6" and float(vals["extrusion_multiplier"]) == 0.9


def test_bad_flow_ratio_is_a_one_line_error():
    with pytest.raises(SettingsError, match="filament_flow_ratio") as info:
        S.from_prusa_config({"filament_flow_ratio": "abc"})
    assert "\n" not in str(info.value)
