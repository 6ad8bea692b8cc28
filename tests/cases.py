"""Load cases (interface.md TOML) used by tests in several folders and by the benchmarks.

Tests import this module by name (``tests/`` is on the path, as for ``slicing``); the benchmarks put
``tests/`` on ``sys.path`` first.  Most cases are a part held on one side and loaded on another:
:func:`side_case` writes those, so a test or benchmark states only what differs.
"""

from __future__ import annotations

__all__ = ["side_case", "GRIP_PULL", "END_PULL", "TOWER_PUSH", "BEAM_3PT", "BRACKET_PIN"]


def side_case(
    force: tuple[float, float, float],
    *,
    held: str = "x_min",
    held_within: float = 10.0,
    loaded: str = "x_max",
    loaded_within: float = 10.0,
    part_frame: bool = False,
    support: str = "clamp",
    load: str = "pull",
    obj: str | None = None,
) -> str:
    """A load case holding the part (x, y, z fixed) within ``held_within`` mm of side ``held`` and
    loading it with ``force`` (N, x/y/z) within ``loaded_within`` mm of side ``loaded``.

    ``part_frame`` writes ``frame = "part"`` (coordinates of the part, not the bed); ``support`` and
    ``load`` name the two entries as reports show them; ``obj`` names the object the case is for
    (``object =``, a plate with several).
    """
    frame = ('frame = "part"\n' if part_frame else "") + (f'object = "{obj}"\n' if obj else "")
    fx, fy, fz = (float(f) for f in force)
    return (
        f"version = 1\n{frame}"
        f'[[supports]]\nname = "{support}"\nwhere = {{ side = "{held}", within = {float(held_within)} }}\n'
        'fix = ["x", "y", "z"]\n'
        f'[[loads]]\nname = "{load}"\nwhere = {{ side = "{loaded}", within = {float(loaded_within)} }}\n'
        f"force = [{fx}, {fy}, {fz}]\n"
    )


GRIP_PULL = side_case((1000.0, 0.0, 0.0))
"""Clamped within 10 mm of x_min, 1000 N pulled within 10 mm of x_max (a grip at each end)."""

END_PULL = side_case((1000.0, 0.0, 0.0), loaded_within=0.5)
"""The swarm paper's specimen: clamped within 10 mm of x_min, 1000 N through the end face at x_max
(a pull spread over 10 mm of the long sides as well shears the grip zone and turns the max-|sigma|
direction across the specimen there)."""

TIP_BEND = side_case((0.0, -200.0, 0.0), held_within=5.0, loaded_within=3.0, load="tip")
"""A cantilever: clamped within 5 mm of x_min, 200 N down within 3 mm of x_max (the printability
bench's beam and taper)."""

BRACKET_TIP = side_case(
    (0.0, -300.0, 0.0), held="y_max", held_within=4.0, loaded_within=4.0, support="wall", load="tip"
)
"""An L-bracket: its wall leg clamped within 4 mm of y_max, 300 N down within 4 mm of x_max (the
printability bench's L-bracket)."""

TOWER_PUSH = side_case(
    (100.0, 0.0, 0.0), held="z_min", held_within=0.5, loaded="z_max", loaded_within=0.5,
    part_frame=True, support="base", load="push",
)
"""A standing part held at its base (z_min) and pushed sideways, 100 N along x, at its top."""

BEAM_3PT = """version = 1
frame = "part"
[[supports]]
name = "left"
where = { x_max = 4.0, y_max = 0.5 }
fix = ["x", "y", "z"]
[[supports]]
name = "right"
where = { x_min = 116.0, y_max = 0.5 }
fix = ["y"]
[[loads]]
name = "press"
where = { x_min = 57.0, x_max = 63.0, y_min = 19.5 }
force = [0.0, -500.0, 0.0]
"""
"""Three-point bending of a 120 x 20 mm beam (part frame): held at its bottom corners (the left one
pinned, the right one on a roller), 500 N pressed down over the middle 6 mm of its top."""

BRACKET_PIN = """version = 1
frame = "part"
[[supports]]
name = "wall"
where = { side = "y_max", within = 0.5 }
fix = ["x", "y", "z"]
[[loads]]
name = "pin"
where = { hole_near = [52.5, 7.5], radius = 5.0 }
force = [0.0, -300.0, 0.0]
"""
"""The L-bracket of ``slicing.bracket_mesh`` (part frame): fixed at the end of its y_max leg, a 300 N
bearing load down on its bolt hole."""
