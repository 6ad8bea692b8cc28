"""Writing a load case back as TOML: parse(to_toml(case)) is the same case, comments name the picks."""

from __future__ import annotations

import dataclasses

import pytest
from loadpath.errors import LoadCaseError
from loadpath.loadcase import Body, describe_pick, empty_selections, parse, resolve, resolve_body, to_toml
from shapely.geometry import Point, box

SPECIMEN = box(50, 87, 200, 123).difference(Point(125, 105).buffer(3, quad_segs=32))

FULL = """
version = 1
object = "spécimen \\"A\\""
frame = "part"
[material]
youngs_modulus = 2010.5
poissons_ratio = 0.32
[[supports]]
name = "clamp"
where = { side = "x_min", within = 10.0 }
fix = ["z", "x"]
[[supports]]
name = "box"
where = { x_min = -1.0, y_max = 3.25e-3, z_min = 0.0 }
fix = ["y"]
[[loads]]
name = "pin"
where = { hole_near = [75.0, 18.0], radius = 0.5 }
force = [0.0, -500.0, 0.0]
[[loads]]
name = "push"
where = { x_min = 140.0 }
pressure = -2.5
[toolpath]
engine = "streamlines"
pitch = 0.41
K = 5
principal = "alternate"
replace = ["solid", "sparse"]
density = "stack"
sparse_fill = 0.25
sparse_engine = "streamlines"
"""


def _same(a, b):
    return dataclasses.replace(a, source="x") == dataclasses.replace(b, source="x")


def test_round_trip_keeps_every_field():
    lc = parse(FULL, "full.toml")
    text = to_toml(lc, header="made on part.stl")
    assert text.startswith("# made on part.stl\nversion = 1\n")
    assert _same(parse(text), lc)
    # the defaults stay defaults: a minimal case gains only the explicit material and frame
    small = parse(
        'version = 1\n[[supports]]\nwhere = { side = "x_min", within = 1.0 }\nfix = ["x", "y"]\n'
        '[[loads]]\nwhere = { side = "x_max", within = 1.0 }\nforce = [1.0, 0.0, 0.0]\n'
    )
    assert _same(parse(to_toml(small)), small)
    assert "[toolpath]" not in to_toml(small)


def test_comments_name_what_each_selector_picked():
    lc = parse(
        'version = 1\n[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 0.5 }\n'
        'fix = ["x", "y"]\n[[loads]]\nname = "pin"\nwhere = { hole_near = [125.0, 105.0], radius = 1.0 }\n'
        'force = [1000.0, 0.0, 0.0]\n[[loads]]\nname = "miss"\nwhere = { x_min = 500.0 }\n'
        "force = [1.0, 0.0, 0.0]\n",
        "c.toml",
    )
    body = Body.from_layers("spec", [(0.0, 2.0, SPECIMEN)])
    rb = resolve_body(lc, body, check=False)
    picks = {s.name: describe_pick(s, rb.analysis) for s in rb.selections}
    assert picks["pin"].startswith("picks the hole at x 125.00, y 105.00 (6.00 mm across)")
    assert picks["clamp"].startswith("picks 37.00 mm of outline in x 50.00..50.50")
    assert picks["miss"] == "picks nothing"
    # the editor lists every empty selection, each with run's own message
    empty = empty_selections(rb)
    assert [s.name for s, _ in empty] == ["miss"]
    with pytest.raises(LoadCaseError) as err:
        resolve(lc, [body])
    assert str(err.value) == empty[0][1]
    text = to_toml(lc, picks)
    assert "[[loads]]\n# picks the hole at x 125.00" in text
    assert _same(parse(text), lc)
