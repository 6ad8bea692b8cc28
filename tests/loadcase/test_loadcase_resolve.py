"""Selectors on the part boundary, bodies as slab stacks, and the 2D / 3D decision."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.errors import GeometryError, LoadCaseError
from loadpath.loadcase import Body, Slab, merge_slabs, parse, resolve
from shapely.geometry import Point, box

SPECIMEN = box(50, 87, 200, 123).difference(Point(125, 105).buffer(3, quad_segs=32))


def _layers(outline, n=10, dz=0.2, z0=0.0):
    return [(z0 + i * dz, z0 + (i + 1) * dz, outline) for i in range(n)]


def _case(supports: str, loads: str, head: str = "version = 1") -> str:
    return f"{head}\n{supports}\n{loads}\n"


CLAMP = '[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 10.0 }\nfix = ["x", "y", "z"]'
PULL = '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 10.0 }\nforce = [1000.0, 0.0, 0.0]'


def test_side_selector_picks_the_end_and_the_sides_near_it():
    (rb,) = resolve(parse(_case(CLAMP, PULL), "case.toml"), [Body.from_layers("spec", _layers(SPECIMEN))])
    assert rb.analysis == "2d" and len(rb.body.slabs) == 1 and rb.thickness == pytest.approx(2.0)
    clamp = rb.supports[0][1]
    # end edge (36 mm) and the two side edges within 10 mm of x_min, over the 2 mm height
    assert clamp.lines.length == pytest.approx(36 + 2 * 10, abs=1e-3)
    assert clamp.measure("2d") == pytest.approx(56 * 2.0, abs=1e-2)
    assert clamp.measure("3d") == pytest.approx(56 * 2.0 + 2 * 10 * 36, abs=1e-2)  # + bottom and top strips
    entry = rb.load_entry()
    assert entry.length == pytest.approx(56, abs=1e-3)
    assert entry.bounds[0] == pytest.approx(190.0, abs=1e-3)
    # the ends of the picked pieces are the points the mesh must have
    assert {tuple(np.round(p, 3)) for p in rb.split_points()} >= {
        (60.0, 87.0),
        (60.0, 123.0),
        (190.0, 87.0),
        (190.0, 123.0),
    }


def test_hole_selector_picks_the_nearest_hole_within_the_radius():
    two = box(0, 0, 100, 40).difference(Point(30, 20).buffer(4)).difference(Point(70, 20).buffer(2))
    case = _case(
        CLAMP,
        '[[loads]]\nname = "pin"\nwhere = { hole_near = [66.0, 20.0], radius = 3.0 }\nforce = [0, -50, 0]',
    )
    (rb,) = resolve(parse(case), [Body.from_layers("b", _layers(two))])
    ((_, _, ring),) = rb.loads[0][1].holes
    assert Point(ring.coords[0]).distance(Point(70, 20)) == pytest.approx(2.0, abs=1e-6)
    assert rb.loads[0][0].is_bearing


def test_hole_out_of_reach_names_the_distance_and_the_box():
    case = _case(
        CLAMP,
        '[[loads]]\nname = "pin"\nwhere = { hole_near = [125.0, 115.0], radius = 5.0 }\nforce = [0, -50, 0]',
    )
    with pytest.raises(
        LoadCaseError,
        match=r"case\.toml: load 'pin' \(hole_near = \[125\.0, 115\.0\], radius = 5\.0\) selects no boundary "
        r"of object 'spec'; the nearest hole is 7\.000 mm away; part bounding box is x 50\.000\.\.200\.000, "
        r"y 87\.000\.\.123\.000, z 0\.000\.\.2\.000",
    ):
        resolve(parse(case, "case.toml"), [Body.from_layers("spec", _layers(SPECIMEN))])


def test_empty_box_selector_names_selector_and_bounding_box():
    case = _case(CLAMP, '[[loads]]\nname = "pull"\nwhere = { x_min = 300.0 }\nforce = [1000.0, 0.0, 0.0]')
    with pytest.raises(
        LoadCaseError,
        match=r"load 'pull' \(x_min = 300\.0\) selects no boundary of object 'spec'; "
        r"part bounding box is x 50\.000\.\.200\.000",
    ):
        resolve(parse(case, "case.toml"), [Body.from_layers("spec", _layers(SPECIMEN))])


def test_frame_part_moves_selectors_with_the_part():
    loads = '[[loads]]\nname = "pin"\nwhere = { hole_near = [75.0, 18.0], radius = 1.0 }\nforce = [0, -50, 0]'
    case = _case(CLAMP, loads, head='version = 1\nframe = "part"')
    (rb,) = resolve(parse(case), [Body.from_layers("spec", _layers(SPECIMEN))])
    assert len(rb.loads[0][1].holes) == 1
    # bed coordinates in a part-frame load case miss, and the message says which frame applies
    bed = loads.replace("[75.0, 18.0]", "[125.0, 105.0]")
    with pytest.raises(LoadCaseError, match=r"relative to its minimum corner: frame = \"part\""):
        resolve(
            parse(_case(CLAMP, bed, head='version = 1\nframe = "part"')),
            [Body.from_layers("spec", _layers(SPECIMEN))],
        )


def test_object_filter():
    a = Body.from_layers("a", _layers(box(0, 0, 10, 10)))
    b = Body.from_layers("b", _layers(box(20, 0, 30, 10)))
    both = resolve(parse(_case(CLAMP, PULL)), [a, b])
    assert [r.name for r in both] == ["a", "b"]
    (only,) = resolve(parse(_case(CLAMP, PULL, head='version = 1\nobject = "b"')), [a, b])
    assert only.name == "b" and only.body.bounds[0][0] == 20
    with pytest.raises(LoadCaseError, match=r"object = 'c' is not in the G-code \(objects found: 'a', 'b'\)"):
        resolve(parse(_case(CLAMP, PULL, head='version = 1\nobject = "c"')), [a, b])


def test_layers_that_agree_become_one_prism_and_a_shrunk_first_layer_is_absorbed():
    shrunk = SPECIMEN.buffer(-0.2, join_style="mitre")  # elephant-foot compensation
    jitter = [SPECIMEN.buffer(0.001 * (i % 3 - 1), join_style="mitre") for i in range(9)]
    layers = [(0.0, 0.2, shrunk)] + [(0.2 * (i + 1), 0.2 * (i + 2), o) for i, o in enumerate(jitter)]
    body = merge_slabs(Body.from_layers("spec", layers))
    assert len(body.slabs) == 1 and body.z_range == (0.0, 2.0)
    assert abs(body.slabs[0].outline.area - SPECIMEN.area) < 0.01 * SPECIMEN.area
    # a real step is kept
    step = Body.from_layers("step", _layers(box(0, 0, 40, 10), 5) + _layers(box(0, 0, 20, 10), 5, z0=1.0))
    merged = merge_slabs(step)
    assert [(s.z0, s.z1) for s in merged.slabs] == [
        (0.0, pytest.approx(1.0)),
        (pytest.approx(1.0), pytest.approx(2.0)),
    ]


def test_analysis_is_3d_for_steps_z_loads_and_top_face_selectors():
    flat = Body.from_layers("p", _layers(box(0, 0, 40, 10)))
    step = Body.from_layers("s", _layers(box(0, 0, 40, 10), 5) + _layers(box(0, 0, 20, 10), 5, z0=1.0))
    assert resolve(parse(_case(CLAMP, PULL)), [flat])[0].analysis == "2d"
    (rb,) = resolve(parse(_case(CLAMP, PULL)), [step])
    assert rb.analysis == "3d" and "2 distinct regions" in rb.reason
    zload = '[[loads]]\nname = "push"\nwhere = { side = "x_max", within = 1.0 }\nforce = [0.0, 0.0, -10.0]'
    assert resolve(parse(_case(CLAMP, zload)), [flat])[0].analysis == "3d"
    top = (
        '[[loads]]\nname = "press"\nwhere = { x_min = 10, x_max = 20, y_min = 2, y_max = 8 }\npressure = 1.0'
    )
    (rb,) = resolve(parse(_case(CLAMP, top)), [flat])
    assert rb.analysis == "3d" and rb.reason == "a selector picks only top or bottom faces"
    assert rb.loads[0][1].area_faces == pytest.approx(2 * 10 * 6, rel=1e-4)


def test_bad_bodies():
    with pytest.raises(GeometryError, match=r"not contiguous"):
        Body("x", (Slab(0, 1, box(0, 0, 1, 1)), Slab(2, 3, box(0, 0, 1, 1))))
    with pytest.raises(GeometryError, match=r"slab z range 1\.0\.\.1\.0 mm is empty"):
        Slab(1.0, 1.0, box(0, 0, 1, 1))
    with pytest.raises(GeometryError, match=r"part outline is empty"):
        Slab(0.0, 1.0, box(0, 0, 1, 1).difference(box(-1, -1, 2, 2)))


def test_a_selector_far_off_the_part_suggests_frame_part():
    # the specimen sits at x 50..200, y 87..123: a box measured from the part's corner (x >= 290)
    # misses by 90 mm, less than the part's 150 mm: no hint; x_min = 400 misses by 200 mm: the hint
    near = _case(CLAMP, '[[loads]]\nname = "pull"\nwhere = { x_min = 290.0 }\nforce = [1, 0, 0]')
    with pytest.raises(LoadCaseError) as exc:
        resolve(parse(near, "case.toml"), [Body.from_layers("spec", _layers(SPECIMEN))])
    assert "frame" not in str(exc.value)
    far = _case(CLAMP, '[[loads]]\nname = "pull"\nwhere = { x_min = 400.0 }\nforce = [1, 0, 0]')
    with pytest.raises(LoadCaseError, match=r"200 mm off a part 150 mm across: .*put frame = \"part\""):
        resolve(parse(far, "case.toml"), [Body.from_layers("spec", _layers(SPECIMEN))])


def test_hole_near_without_radius_takes_the_nearest_hole_within_its_diameter():
    two = box(0, 0, 100, 40).difference(Point(30, 20).buffer(4)).difference(Point(70, 20).buffer(2))
    pin = '[[loads]]\nname = "pin"\nwhere = { hole_near = [75.0, 20.0] }\nforce = [0, -50, 0]'
    (rb,) = resolve(parse(_case(CLAMP, pin)), [Body.from_layers("b", _layers(two))])
    ((_, _, ring),) = rb.loads[0][1].holes  # 3 mm from the 4 mm hole at (70, 20): within its diameter
    assert Point(ring.coords[0]).distance(Point(70, 20)) == pytest.approx(2.0, abs=1e-6)
    far = pin.replace("[75.0, 20.0]", "[77.0, 20.0]")  # 5 mm from a 4 mm hole: none
    with pytest.raises(LoadCaseError, match=r"hole_near = \[77\.0, 20\.0\]\) selects no boundary"):
        resolve(parse(_case(CLAMP, far)), [Body.from_layers("b", _layers(two))])


def test_a_load_on_a_supported_edge_is_named_with_the_share_it_loses():
    """Support within 10 mm of x_min, load within 20 mm of it: the end face and 10 of the load's 20 mm
    along each long side are held, (36 + 2 * 10) of (36 + 2 * 20) mm: 74 % of the load never loads the
    part.  The solver refuses only a load held everywhere; this share was lost without a word."""
    spec = [Body.from_layers("spec", _layers(SPECIMEN))]
    hang = '[[loads]]\nname = "hang"\nwhere = { side = "x_min", within = 20.0 }\nforce = [0.0, -100.0, 0.0]'
    (rb,) = resolve(parse(_case(CLAMP, hang)), spec)
    (w,) = rb.held_loads()
    assert "load 'hang' acts where support 'clamp' holds the part on 74% of its edge" in w
    (rb,) = resolve(parse(_case(CLAMP, PULL)), spec)
    assert rb.held_loads() == []
