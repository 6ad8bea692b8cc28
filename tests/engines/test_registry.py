"""The engine registry: adding an engine is one ``register`` call, and every front end then knows it.

A small engine (straight lines across the region, one pitch apart) is registered here and nowhere
else; the command line, the settings schema, the Cura plugin's generated settings, the load case's
``[toolpath] engine`` and the demo accept it, and ``loadpath run`` prints its paths into the shipped
example (the pipeline staggers them itself: the engine does not lay a copy of its own), handing it
the machine facts it declares.
"""

from __future__ import annotations

import argparse
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import shapely
from loadpath import engines, gcode, loadcase
from loadpath.errors import LoadCaseError, SettingsError
from loadpath.plugin import settings as S
from loadpath.plugin.cli import main
from loadpath.plugin.commands import demo
from loadpath.toolpath import EngineInput, Toolpaths
from loadpath.toolpath import Path as ToolPath

REPO = Path(__file__).resolve().parents[2]
CASE = """version = 1
[toolpath]
engine = "lines"
[[supports]]
where = { side = "x_min", within = 5.0 }
fix = ["x", "y", "z"]
[[loads]]
where = { side = "x_max", within = 5.0 }
force = [100.0, 0, 0]
"""
SEEN: list[dict] = []


@dataclass(frozen=True)
class LineOptions:
    """Options of the test engine."""

    angle: float = 0.0


def generate(inp: EngineInput, angle: float = 0.0, nozzle: float | None = None) -> Toolpaths:
    """Lines at ``angle`` degrees across the region, one pitch apart, clipped to it."""
    SEEN.append({"nozzle": nozzle, "pitch": inp.pitch})
    x0, y0, x1, y1 = inp.region.bounds
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    reach = float(np.hypot(x1 - x0, y1 - y0))
    mid = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    paths = []
    for off in np.arange(-reach / 2, reach / 2, inp.pitch):
        a = mid + off * np.array([-s, c]) - reach * np.array([c, s])
        b = mid + off * np.array([-s, c]) + reach * np.array([c, s])
        cut = shapely.intersection(shapely.LineString([a, b]), inp.region.buffer(-0.5 * inp.pitch))
        for g in shapely.get_parts(cut):
            if g.geom_type == "LineString" and g.length > 2 * inp.pitch:
                pts = np.asarray(g.coords)
                paths.append(ToolPath(pts, np.full(len(pts), inp.pitch)))
    return Toolpaths(tuple(paths), {"lines": len(paths)})


@pytest.fixture()
def lines_engine():
    engines.register(
        engines.Engine(
            name="lines",
            module=__name__,
            options=f"{__name__}:LineOptions",
            summary="straight lines (test)",
            machine=("nozzle",),
        )
    )
    SEEN.clear()
    try:
        yield
    finally:
        engines.unregister("lines")


def test_a_registered_engine_is_known_to_every_front_end(lines_engine):
    assert "lines" in engines.NAMES and list(engines.NAMES)[:2] == ["swarm", "streamlines"]
    assert "lines" in S.ENGINES
    assert "lines" in next(f for f in S.SCHEMA if f.name == "engine").choices
    assert "lines" in S.cura_setting_definitions()["engine"]["options"]
    parser = argparse.ArgumentParser()
    S.add_cli_options(parser)
    assert S.cli_values(parser.parse_args(["--engine", "lines"]))["engine"] == "lines"
    dp = argparse.ArgumentParser()
    demo.add_args(dp)
    assert dp.parse_args(["--engine", "lines"]).engine == "lines"
    case = loadcase.parse(CASE)
    assert case.toolpath.engine == "lines"
    assert engines.get("lines").options_class() is LineOptions
    assert not engines.get("lines").lays_phase({})


def test_unregistered_names_are_refused_with_the_list(lines_engine):
    engines.unregister("lines")
    with pytest.raises(SettingsError, match="engine = 'lines' is unknown; use one of swarm, streamlines"):
        engines.get("lines")
    with pytest.raises(LoadCaseError, match="toolpath.engine"):
        loadcase.parse(CASE)
    with pytest.raises(SettingsError, match="registered already"):
        engines.register(engines.get("swarm"))


def test_loadpath_run_prints_the_registered_engine(lines_engine, tmp_path, capsys):
    g = tmp_path / "ohs.gcode"
    shutil.copyfile(REPO / "examples" / "ohs.gcode", g)
    out = tmp_path / "out.gcode"
    rc = main(
        [
            "run",
            str(g),
            "--loadcase",
            str(REPO / "examples" / "ohs.toml"),
            "--engine",
            "lines",
            "-o",
            str(out),
        ]
    )
    assert rc == 0, capsys.readouterr().err
    assert SEEN and all(s["nozzle"] == pytest.approx(0.4) for s in SEEN)  # the machine fact it declared
    program, result = gcode.read(g), gcode.read(out)
    assert result.to_bytes() != program.to_bytes()
    # the replaced layers print straight lines along x (angle 0): every new solid-infill move is
    # horizontal, where the slicer's were at +-45 degrees
    moves = result.moves[result.moves["extrude"] & (result.moves["role"] == int(gcode.Role.SOLID_INFILL))]
    dx, dy = moves["x1"] - moves["x0"], moves["y1"] - moves["y0"]
    long = np.hypot(dx, dy) > 1.0
    assert long.sum() > 100
    assert np.median(np.abs(dy[long]) / np.hypot(dx[long], dy[long])) < 1e-3
