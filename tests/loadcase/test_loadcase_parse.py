"""Reading and validating load-case files (interface.md, version 1)."""

from __future__ import annotations

import math

import pytest
from loadpath.errors import LoadCaseError
from loadpath.loadcase import BoxSelector, HoleSelector, SideSelector, parse, read

GOOD = """
version = 1
object = "bracket"
frame = "part"

[material]
youngs_modulus = 2300
poissons_ratio = 0.33

[[supports]]
name = "clamp"
where = { side = "x_min", within = 10.0 }
fix = ["y", "x"]

[[supports]]
name = "pin"
where = { hole_near = [20.0, 10.0], radius = 5 }
fix = ["z"]

[[loads]]
name = "pull"
where = { x_min = 140.0, y_max = 30 }
force = [1000.0, 0.0, 0.0]

[[loads]]
name = "press"
where = { side = "y_max", within = 0.5 }
pressure = 2.0

[toolpath]
engine = "streamlines"
pitch = 0.41
K = 5.0
principal = "alternate"
replace = ["solid", "sparse"]
"""


def test_good_file_round_trip(tmp_path):
    p = tmp_path / "case.toml"
    p.write_text(GOOD)
    lc = read(p)
    assert lc.source == "case.toml"
    assert lc.object == "bracket" and lc.frame == "part"
    assert lc.material.E == 2300.0 and lc.material.nu == 0.33
    clamp, pin = lc.supports
    assert clamp.where == SideSelector("x_min", 10.0) and clamp.fix == ("x", "y")
    assert pin.where == HoleSelector((20.0, 10.0), 5.0) and pin.fixed_axes == (2,)
    pull, press = lc.loads
    assert isinstance(pull.where, BoxSelector)
    assert pull.where.lower == (140.0, -math.inf, -math.inf) and pull.where.upper == (
        math.inf,
        30.0,
        math.inf,
    )
    assert pull.force == (1000.0, 0.0, 0.0) and press.pressure == 2.0
    assert lc.toolpath.engine == "streamlines" and lc.toolpath.replace == ("solid", "sparse")
    # pin holds only z, which only a 3D analysis can honour
    assert lc.needs_3d


def test_defaults():
    lc = parse(
        'version = 1\n[[supports]]\nwhere = { side = "x_min", within = 1 }\nfix = ["x", "y"]\n'
        '[[loads]]\nwhere = { side = "x_max", within = 1 }\nforce = [1, 0, 0]\n'
    )
    assert lc.material.E == 3500.0 and lc.material.nu == 0.35  # PLA
    assert lc.frame == "bed" and lc.object is None
    assert lc.supports[0].name == "support 1" and lc.loads[0].name == "load 1"
    assert not lc.needs_3d


def _case(**sections: str) -> str:
    parts = {
        "head": "version = 1",
        "material": "",
        "supports": '[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 1.0 }\n'
        'fix = ["x", "y", "z"]',
        "loads": '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\n'
        "force = [100.0, 0.0, 0.0]",
    }
    parts.update(sections)
    return "\n".join(parts.values()) + "\n"


@pytest.mark.parametrize(
    "text, match",
    [
        ("version = 1\n[[supports]\n", r"case\.toml: not valid TOML"),
        (
            _case(head="version = 1\nunits = 'mm'"),
            r"unknown key 'units' in the top level; expected one of version",
        ),
        (_case(head=""), r"missing key 'version'; add version = 1"),
        (_case(head="version = 2"), r"version = 2 is not supported"),
        (_case(head='version = "1"'), r"version = '1' must be the integer 1"),
        (
            _case(head='version = 1\nframe = "world"'),
            r"frame = 'world' is not valid; use one of 'bed', 'part'",
        ),
        (_case(supports=""), r"missing section \[\[supports\]\]"),
        (_case(loads=""), r"missing section \[\[loads\]\]"),
        (
            _case(supports="[supports]\nfix = ['x']"),
            r"\[supports\] must be an array of tables: write \[\[supports\]\]",
        ),
        (
            _case(material="[material]\nyoungs_modulus = 0"),
            r"material\.youngs_modulus = 0\.0 must be > 0 MPa",
        ),
        (
            _case(material="[material]\nyoungs_modulus = -3500"),
            r"material\.youngs_modulus = -3500\.0 must be > 0 MPa",
        ),
        (  # PLA's modulus in GPa where MPa is asked
            _case(material="[material]\nyoungs_modulus = 3.5"),
            r"material\.youngs_modulus = 3\.5 MPa is outside what printers print .*\(3\.5 GPa is 3500 MPa\)",
        ),
        (
            _case(material="[material]\nyoungs_modulus = '3500'"),
            r"material\.youngs_modulus = '3500' must be a number \(MPa\)",
        ),
        (
            _case(material="[material]\npoissons_ratio = 0.5"),
            r"material\.poissons_ratio = 0\.5 must lie in \(-1, 0\.5\)",
        ),
        (
            _case(material="[material]\npoissons_ratio = -1.0"),
            r"material\.poissons_ratio = -1\.0 must lie in \(-1, 0\.5\)",
        ),
        (_case(material="[material]\ndensity = 1.2"), r"unknown key 'density' in \[material\]"),
        (
            _case(
                loads='[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\n'
                "force = [0, 0.0, 0]"
            ),
            r"loads\[0\] \('pull'\)\.force = \[0\.0, 0\.0, 0\.0\] is zero",
        ),
        (
            _case(loads='[[loads]]\nname = "p"\nwhere = { side = "x_max", within = 1.0 }\npressure = 0'),
            r"loads\[0\] \('p'\)\.pressure = 0 is zero",
        ),
        (
            _case(loads='[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\nforce = [1, 0]'),
            r"force = \[1, 0\] must be a list of 3 numbers \(N\)",
        ),
        (
            _case(
                loads='[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\n'
                'force = ["1", 0, 0]'
            ),
            r"force\[0\] = '1' must be a number \(N\)",
        ),
        (
            _case(
                loads='[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\n'
                "force = [1, 0, 0]\npressure = 1"
            ),
            r"needs exactly one of force .* or pressure .*; it has both",
        ),
        (
            _case(
                loads='[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\nforc = [1, 0, 0]'
            ),
            r"unknown key 'forc' in loads\[0\]; expected one of name, where, force, pressure",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = { side = "left", within = 1.0 }\nfix = ["x"]'),
            r"supports\[0\] \('c'\)\.where\.side = 'left' is not valid; use one of 'x_min'",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = { side = "x_min" }\nfix = ["x"]'),
            r"needs both side and within",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = { side = "x_min", within = -1 }\nfix = ["x"]'),
            r"within = -1\.0 must be >= 0 mm",
        ),
        (
            _case(
                supports='[[supports]]\nname = "c"\nwhere = { hole_near = [1, 2], radius = 0 }\nfix = ["x"]'
            ),
            r"radius = 0\.0 must be > 0 mm",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = { x_min = 5, x_max = 1 }\nfix = ["x"]'),
            r"x_min = 5\.0 is above x_max = 1\.0; swap them",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = { x_min = 5, side = "x_min" }\nfix = ["x"]'),
            r"unknown key 'x_min' in supports\[0\] \('c'\)\.where; expected one of side, within",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = { side = "x_min", within = 1 }\nfix = ["w"]'),
            r"supports\[0\] \('c'\)\.fix contains 'w'; use any of",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = { side = "x_min", within = 1 }\nfix = "x"'),
            r"fix = 'x' must be a non-empty list",
        ),
        (
            _case(
                supports='[[supports]]\nname = "c"\nwhere = { side = "x_min", within = 1 }\nfix = ["x", "x"]'
            ),
            r"lists 'x' twice",
        ),
        (
            _case(supports='[[supports]]\nname = "c"\nwhere = "x_min"\nfix = ["x"]'),
            r"\.where = 'x_min' must be a table",
        ),
        (
            _case(
                supports='[[supports]]\nname = "pull"\nwhere = { side = "x_min", within = 1 }\nfix = ["x"]'
            ),
            r"the name 'pull' is used twice",
        ),
        (
            _case(head='version = 1\n[toolpath]\nengine = "zigzag"'),
            r"toolpath\.engine = 'zigzag' is not valid; use one of 'swarm', 'streamlines'",
        ),
        (_case(head="version = 1\n[toolpath]\npitch = 0"), r"toolpath\.pitch = 0\.0 must be > 0 mm"),
        (
            _case(head='version = 1\n[toolpath]\nreplace = ["walls"]'),
            r"toolpath\.replace\[\] = 'walls' is not valid",
        ),
        (
            _case(head='version = 1\n[toolpath]\nprincipal = "major"'),
            r"toolpath\.principal = 'major' is not valid",
        ),
    ],
)
def test_bad_files_name_the_key_and_value(text, match):
    with pytest.raises(LoadCaseError, match=match):
        parse(text, source="case.toml")


def test_unreadable_file(tmp_path):
    with pytest.raises(LoadCaseError, match=r"cannot read load case .*missing\.toml"):
        read(tmp_path / "missing.toml")


def test_messages_are_one_line():
    with pytest.raises(LoadCaseError) as e:
        parse("version = 1\n[[supports]\n", source="case.toml")
    assert "\n" not in str(e.value)
