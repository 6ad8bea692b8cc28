"""Fixtures of the geometry tests: a stepped part (a plate with a boss on one half), sliced for real.

The step's top face is half exposed, half under the boss: the layer that carries it is the case where
a slicer's type name (Cura's ``SKIN`` for everything) does not say whether infill is a top skin.
"""

from __future__ import annotations

import conftest as _root  # tests/conftest.py (require_tool)
import pytest
import slicing
import trimesh
from fixtures import made_once  # tests/fixtures.py: one slice per run, shared by xdist workers


def step_mesh() -> trimesh.Trimesh:
    """A 40 x 20 x 2 plate with a 20 x 20 x 2 boss on its low-x half (4 mm high, 20 layers)."""
    plate = trimesh.creation.box(extents=(40, 20, 2))
    plate.apply_translation((20, 10, 1))
    boss = trimesh.creation.box(extents=(20, 20, 2))
    boss.apply_translation((10, 10, 3))
    mesh = plate.union(boss)
    mesh.apply_translation(-mesh.bounds[0])
    return mesh


@pytest.fixture(scope="session")
def sliced_step(slice_cache):
    """Factory ``sliced_step(slicer, settings) -> Path`` of the stepped part's real G-code."""

    def make(slicer: str, settings: str = "mixed"):
        _root.require_tool("prusa-slicer" if slicer == "prusa" else "CuraEngine")
        if slicer == "cura":
            _root.require_tool("cura")
        stl = slice_cache / "step.stl"
        made_once(stl, lambda: slicing.write_stl(step_mesh(), stl))
        out = slice_cache / f"{slicer}-step-{settings}.gcode"

        def slice_it() -> None:
            conf = {"prusa": {"mixed": slicing.PRUSA_MIXED, "solid": slicing.PRUSA_SOLID},
                    "cura": {"mixed": slicing.CURA_MIXED, "solid": slicing.CURA_SOLID}}[slicer][settings]
            (slicing.slice_prusa if slicer == "prusa" else slicing.slice_cura)(stl, out, **conf)

        return made_once(out, slice_it)

    return make
