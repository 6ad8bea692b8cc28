"""Layer geometry from real PrusaSlicer 2.5 / CuraEngine 4.13 output: outlines, domains, islands, objects."""

from __future__ import annotations

import math

import geometry_fixtures
import numpy as np
import pytest
import shapely
from loadpath import gcode, geometry
from loadpath.areal import polygons_of
from loadpath.errors import GeometryError
from loadpath.geometry.regions import check_tolerance

sliced_step = geometry_fixtures.sliced_step  # the stepped part, sliced for real

ROUND_LOSS = 1 - math.pi / 4  # PrusaSlicer: a bead of width w and height h tiles at w - h (1 - pi/4)


def _geo(path):
    return geometry.layer_geometry(gcode.read(path))


def _number(config, key):
    value = config[key]
    assert value.replace(".", "", 1).isdigit(), f"{key} = {value} is not a plain width in mm"
    return float(value)


def prusa_perimeter_inset(config) -> float:
    """Distance from the sliced contour to the inner edge of the innermost perimeter, PrusaSlicer.

    PrusaSlicer's flow model (PerimeterGenerator, Flow::spacing): a bead of width ``w`` and height
    ``h`` tiles at the spacing ``s = w - h (1 - pi/4)``.  The external perimeter's centre line lies
    ``we / 2`` inside the contour, the second loop ``(se + sp) / 2`` further in, every further loop
    ``sp`` further, and the innermost loop's inner edge ``sp / 2`` beyond its centre line:

        t = we/2 + (se + sp)/2 + (n - 2) sp + sp/2        (n >= 2 perimeters)
        t = we/2 + se/2                                    (n = 1)
    """
    h = _number(config, "layer_height")
    we = _number(config, "external_perimeter_extrusion_width")
    wp = _number(config, "perimeter_extrusion_width")
    n = int(config["perimeters"])
    se, sp = we - h * ROUND_LOSS, wp - h * ROUND_LOSS
    if n == 1:
        return we / 2 + se / 2
    return we / 2 + (se + sp) / 2 + (n - 2) * sp + sp / 2


def specimen_domain_area(t: float, length=150.0, width=36.0, hole=6.0) -> float:
    """The 150 x 36 rectangle minus the 6 mm hole, each offset inwards (into the part) by t."""
    return (length - 2 * t) * (width - 2 * t) - math.pi * (hole / 2 + t) ** 2


@pytest.mark.parametrize("fixture", ["prusa_ohs", "prusa_ohs_solid"])
def test_specimen_domain_equals_analytic_value_prusa(fixture, request):
    path = request.getfixturevalue(fixture)
    program = gcode.read(path)
    t = prusa_perimeter_inset(program.config)
    assert t == pytest.approx(0.83562, abs=1e-5)  # MK3S: 2 perimeters of 0.45 mm at 0.2 mm
    expected = specimen_domain_area(t)
    (obj,) = geometry.layer_geometry(program).objects
    internal = obj.layers[1:-1]  # the first layer is shrunk by elephant-foot compensation
    assert len(internal) == 8
    for g in internal:
        (island,) = g.islands
        assert island.domain.area == pytest.approx(expected, rel=0.005), g.layer_index
        assert island.domain.area == pytest.approx(expected, rel=0.0005)  # what we actually reach
        (poly,) = polygons_of(island.domain)
        assert len(poly.interiors) == 1  # the hole, grown by the walls around it


@pytest.mark.parametrize("perimeters", [1, 3])
def test_specimen_domain_other_perimeter_counts(perimeters, sliced):
    program = gcode.read(sliced("prusa", "ohs", "mixed", perimeters=perimeters))
    assert int(program.config["perimeters"]) == perimeters
    expected = specimen_domain_area(prusa_perimeter_inset(program.config))
    for g in geometry.layer_geometry(program).objects[0].layers[1:-1]:
        assert g.islands[0].domain.area == pytest.approx(expected, rel=0.001)


def test_specimen_domain_equals_analytic_value_cura(cura_ohs):
    # CuraEngine's rectangle model: walls tile at their line width; the prusa_i3_mk3 definition has
    # 0.4 mm lines and wall_thickness 0.8 mm, so 2 walls: t = w0 + (n - 1) wx = 0.8 mm.
    (obj,) = _geo(cura_ohs).objects
    for g in obj.layers:
        assert g.islands[0].domain.area == pytest.approx(specimen_domain_area(0.8), rel=0.001)


@pytest.mark.parametrize("fixture", ["prusa_ohs", "cura_ohs"])
def test_specimen_outline_is_the_part(fixture, request):
    (obj,) = _geo(request.getfixturevalue(fixture)).objects
    hole = 0.5 * 64 * 9 * math.sin(2 * math.pi / 64)  # the STL's 64-gon
    for g in obj.layers[1:]:
        (island,) = g.islands
        assert island.outline.area == pytest.approx(150 * 36 - hole, rel=0.001)
        assert len(island.outline.interiors) == 1
        x0, y0, x1, y1 = island.outline.bounds
        assert x1 - x0 == pytest.approx(150, abs=0.01) and y1 - y0 == pytest.approx(36, abs=0.01)
        ring = shapely.Polygon(island.outline.interiors[0])
        assert ring.centroid.x == pytest.approx((x0 + x1) / 2, abs=0.02)
        assert ring.centroid.y == pytest.approx((y0 + y1) / 2, abs=0.02)


def test_first_layer_outline_shows_elephant_foot_compensation(prusa_ohs):
    program = gcode.read(prusa_ohs)
    comp = float(program.config["elefant_foot_compensation"])
    (obj,) = geometry.layer_geometry(program).objects
    first, second = obj.layers[0].outline, obj.layers[1].outline
    b0, b1 = np.array(first.bounds), np.array(second.bounds)
    np.testing.assert_allclose(b0 - b1, [comp, comp, -comp, -comp], atol=0.01)


@pytest.mark.parametrize("fixture", ["prusa_ohs", "cura_ohs", "prusa_bracket", "cura_bracket",
                                     "prusa_two_islands", "cura_two_islands", "prusa_tower", "cura_tower"])
def test_domain_is_the_outline_offset_by_the_walls(fixture, request):
    """Every internal layer: the domain's boundary is the outline's offset by the wall inset, to 0.05 mm.

    At reflex corners PrusaSlicer's Arachne walls round the inset (round join), CuraEngine 4.13 keeps it
    sharp (mitre join); the reference is offset the same way.
    """
    program = gcode.read(request.getfixturevalue(fixture))
    prusa = program.dialect.family == "prusa"
    t = prusa_perimeter_inset(program.config) if prusa else 0.8
    (obj,) = geometry.layer_geometry(program).objects
    for g in obj.layers[1:]:
        for island in g.islands:
            ref = island.outline.buffer(-t, join_style="round" if prusa else "mitre")
            assert shapely.hausdorff_distance(ref.boundary, island.domain.boundary) < 0.05, g.layer_index


@pytest.mark.parametrize("slicer", ["prusa", "cura"])
def test_two_islands_of_one_object(slicer, sliced):
    (obj,) = _geo(sliced(slicer, "two_islands")).objects
    assert len(obj.layers) == 10
    for g in obj.layers[1:]:
        assert len(g.islands) == 2
        for island in g.islands:
            assert island.outline.area == pytest.approx(40 * 20, rel=0.002)
            assert len(island.blocks) >= 1
            assert all(island.domain.covers(b.region) for b in island.blocks)
        a, b = g.islands
        assert b.outline.bounds[0] - a.outline.bounds[2] == pytest.approx(10.0, abs=0.02)  # the 10 mm gap


@pytest.mark.parametrize("slicer", ["prusa", "cura"])
def test_two_objects_are_named_and_stacked(slicer, sliced):
    geo = _geo(sliced(slicer, "two_objects"))
    assert [o.name for o in geo.objects] == ["two_islands.stl", "bracket.stl"]
    islands, bracket = geo.objects
    assert len(islands.layers) == 10 and len(bracket.layers) == 15
    assert all(len(g.islands) == 2 for g in islands.layers)
    assert all(len(g.islands) == 1 for g in bracket.layers)
    stack = bracket.layer_stack()
    assert stack[0][0] == pytest.approx(0.0) and stack[-1][1] == pytest.approx(3.0)
    assert all(a[1] == pytest.approx(b[0]) for a, b in zip(stack[:-1], stack[1:], strict=True))
    bodies = geo.bodies()
    assert [b.name for b in bodies] == ["two_islands.stl", "bracket.stl"]
    assert geo.object("bracket.stl") is bracket
    assert geo.object(bracket.label) is bracket
    with pytest.raises(KeyError, match="two_islands.stl, bracket.stl"):
        geo.object("nope")


@pytest.mark.parametrize("slicer", ["prusa", "cura"])
def test_concave_bracket(slicer, sliced):
    (obj,) = _geo(sliced(slicer, "bracket")).objects
    l_area = 60 * 15 + 15 * 25 - 0.5 * 48 * 2.5**2 * math.sin(2 * math.pi / 48)  # L minus the 48-gon hole
    for g in obj.layers[1:]:
        (island,) = g.islands
        assert island.outline.area == pytest.approx(l_area, rel=0.002)
        assert island.outline.convex_hull.area > 1.3 * island.outline.area  # concave
        assert len(island.outline.interiors) == 1


def test_every_region_holds_its_own_extrusions(sliced, sliced_step):
    """The check the issue asks for, on every real file: each block's lines lie inside its region."""
    paths = [sliced(s, p, k) for s in ("prusa", "cura") for p in ("ohs", "bracket", "two_objects")
             for k in ("mixed", "solid")]
    paths += [sliced_step(s, k) for s in ("prusa", "cura") for k in ("mixed", "solid")]
    n = 0
    for path in paths:
        program = gcode.read(path)
        geo = geometry.layer_geometry(program, check=False)
        m = program.moves
        for obj in geo.objects:
            for g in obj.layers:
                for island in g.islands:
                    for b in island.blocks:
                        n += 1
                        where = (path.name, g.layer_index, b.feature)
                        assert b.outside <= check_tolerance(b.flow_width), where
                        # and nearly all of the block's length lies strictly inside
                        rows = slice(int(program.blocks["move_start"][b.block_index]),
                                     int(program.blocks["move_stop"][b.block_index]))
                        mv = m[rows][m[rows]["extrude"]]
                        mine = shapely.contains_xy(island.outline, (mv["x0"] + mv["x1"]) / 2,
                                                   (mv["y0"] + mv["y1"]) / 2)
                        seg = shapely.linestrings(np.stack([np.c_[mv["x0"], mv["y0"]],
                                                            np.c_[mv["x1"], mv["y1"]]], axis=1)[mine])
                        length = shapely.length(seg).sum()
                        inside = shapely.length(shapely.intersection(seg, b.region.buffer(1e-3))).sum()
                        if length > 10 * b.flow_width:  # specks of two segments are only held to `outside`
                            assert inside >= 0.97 * length, (*where, inside / length)
    assert n > 100


def test_check_raises_when_a_block_leaves_its_region(prusa_ohs):
    """Move one solid infill line 3 mm outside the part: the derived region no longer holds it."""
    text = prusa_ohs.read_bytes().decode()
    program = gcode.read(prusa_ohs)
    b = program.blocks_of(1)[-1]
    assert b.feature == "Solid infill"
    lines = text.split("\n")
    i = next(k for k in range(b.start, b.stop) if lines[k].startswith("G1 X") and " E" in lines[k])
    words = lines[i].split()
    lines[i] = " ".join(w if not w.startswith("Y") else f"Y{float(w[1:]) - 40:.3f}" for w in words)
    bad = gcode.parse("\n".join(lines).encode())
    with pytest.raises(GeometryError, match=r"layer 2 \(z = 0.4 mm\), object 'ohs.stl': the 'Solid infill' "):
        geometry.layer_geometry(bad)
    assert geometry.layer_geometry(bad, check=False).objects[0].layers[1].blocks[0].outside > 1.0


@pytest.mark.parametrize("slicer,setting", [("prusa", {"perimeters": 0}), ("cura", {"wall_line_count": 0})])
def test_layer_without_perimeters_is_a_one_line_error(slicer, setting, sliced):
    program = gcode.read(sliced(slicer, "ohs", "mixed", **setting))
    with pytest.raises(GeometryError) as info:
        geometry.layer_geometry(program)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("layer 1 (z = 0.2 mm), object 'ohs.stl' has infill but no perimeters")
    assert "at least one perimeter" in msg


def test_current_prusaslicer_files_with_arcs_and_labels(repo_root):
    cases = [("prusaslicer-2.7.4-plant-sign-arcs-labels.gcode", ["CorianderIndentExample.stl"], 1),
             ("prusaslicer-2.9.2-calicat-mini-arcs-m486.gcode", ["calicat(1).stl"], 3)]
    for name, objects, islands0 in cases:
        program = gcode.read(repo_root / "tests" / "data" / "current" / name)
        assert program.moves["arc"].any()
        geo = geometry.layer_geometry(program)  # includes the region check
        assert [o.name for o in geo.objects] == objects
        first = geo.objects[0].layers[0]
        assert len(first.islands) == islands0
        assert all(b.kind == "bottom" for b in first.blocks)
        assert all(not i.domain.is_empty and i.domain.area < i.outline.area for i in first.islands)


def test_flow_widths_from_e(prusa_ohs, cura_ohs):
    # PrusaSlicer: ;WIDTH:0.45 at 0.2 mm is a flow width of 0.45 - 0.2 (1 - pi/4) = 0.40708
    geo = _geo(prusa_ohs)
    b = geo.objects[0].layers[2].blocks[0]
    assert b.bead_width == pytest.approx(0.45, abs=1e-5)
    assert b.flow_width == pytest.approx(0.45 - 0.2 * ROUND_LOSS, rel=2e-3)
    # Cura: no ;WIDTH:, rectangle beads of 0.4 mm
    b = _geo(cura_ohs).objects[0].layers[2].blocks[0]
    assert b.flow_width == pytest.approx(0.4, rel=2e-3) and b.bead_width == b.flow_width
    assert geometry.object_names(["a.stl id:0 copy 0", "/x/b.stl", "a.stl id:0 copy 1"]) == \
        ["a.stl id:0 copy 0", "b.stl", "a.stl id:0 copy 1"]


def test_filament_diameter_measured_from_the_walls(cura_ohs):
    """A Cura file carries no filament diameter; a 2.85 mm printer's E is (1.75 / 2.85)^2 of a 1.75 mm one.

    Scaling every E word of real CuraEngine output that way, the walls' spacing (a length E does not
    enter) tells the diameter, and the geometry comes out the same.
    """
    import re

    text = cura_ohs.read_text()
    k = (1.75 / 2.85) ** 2
    scaled = re.sub(r"(?m)^(G[01] [^;\n]*?E)(-?[\d.]+)",
                    lambda mt: f"{mt.group(1)}{float(mt.group(2)) * k:.5f}", text)
    p0, p1 = gcode.parse(text.encode()), gcode.parse(scaled.encode())
    assert geometry.filament_diameter(p0) == (1.75, "default")
    assert geometry.filament_diameter(p1) == (2.85, "wall spacing")
    g0, g1 = geometry.layer_geometry(p0), geometry.layer_geometry(p1)
    assert g1.filament_diameter == 2.85 and g1.filament_source == "wall spacing"
    for a, b in zip(g0.objects[0].layers, g1.objects[0].layers, strict=True):
        assert b.domain.area == pytest.approx(a.domain.area, rel=1e-3)
        assert [x.kind for x in b.blocks] == [x.kind for x in a.blocks]
        assert b.blocks[0].flow_width == pytest.approx(0.4, rel=5e-3)
    assert geometry.wall_spacing(p0) == pytest.approx(0.4, abs=0.005)  # (w0 + wx) / 2


def test_distinct_layers_on_real_files(prusa_ohs, cura_ohs, prusa_tower, repo_root):
    # PrusaSlicer shrinks the first layer (elephant-foot compensation): two outlines; Cura: one
    (obj,) = _geo(prusa_ohs).objects
    assert [g.layers for g in geometry.distinct_layers(obj)] == [(0,), tuple(range(1, 10))]
    (obj,) = _geo(cura_ohs).objects
    assert [g.layers for g in geometry.distinct_layers(obj)] == [tuple(range(10))]
    assert [g.layers for g in geometry.distinct_layers(obj, key="domain")] == [tuple(range(10))]
    # the twisted, tapered tower changes its outline every layer
    (obj,) = _geo(prusa_tower).objects
    assert len(geometry.distinct_layers(obj)) >= 110
    # the shipped example: internal solid replaced on layers 2-9, in two groups (Solid infill and
    # 100 % Internal infill differ in pitch), nothing to replace on the first and last layers
    (obj,) = _geo(repo_root / "examples" / "ohs.gcode").objects
    groups = geometry.distinct_layers(obj, key="replace", kinds=["solid"])
    assert sorted(i for g in groups for i in g.layers) == list(range(1, 9))
    assert len(groups) <= 2
    body = obj.body()
    assert len(body.slabs) == 10 and body.z_range == pytest.approx((0.0, 2.0))
