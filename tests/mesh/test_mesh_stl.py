"""STL models (--model): placing them like the slicer did, and meshing them with quadratic tetrahedra."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath.errors import GeometryError, MeshingError
from loadpath.mesh import mesh_stl
from loadpath.mesh.place import place_stl
from shapely.geometry import Point, box

trimesh = pytest.importorskip("trimesh")
pytest.importorskip("manifold3d")

# where a slicer might put the specimen: centred on a 250 x 210 bed
BED_OUTLINE = box(50, 87, 200, 123).difference(Point(125, 105).buffer(3, quad_segs=16))


@pytest.fixture(scope="module")
def specimen_stl(tmp_path_factory):
    """The open-hole specimen of real-tools.md §9, modelled around the origin, raised by 5 mm."""
    plate = trimesh.creation.box(extents=(150, 36, 2))
    hole = trimesh.creation.cylinder(radius=3, height=4, sections=64)
    part = plate.difference(hole)
    part.apply_translation((0, 0, 6))
    path = tmp_path_factory.mktemp("stl") / "specimen.stl"
    part.export(path)
    return path


def test_place_matches_the_first_layer(specimen_stl):
    T = place_stl(specimen_stl, BED_OUTLINE.buffer(-0.2, join_style="mitre"), 0.2)  # elephant-foot shrunk
    np.testing.assert_allclose(T[:3, 3], [125.0, 105.0, -5.0], atol=1e-6)
    m = mesh_stl(specimen_stl, 4.0, transform=T)
    assert m.cell_type == "tet10" and np.all(m.measures > 0)
    lo, hi = m.points.min(axis=0), m.points.max(axis=0)
    np.testing.assert_allclose(lo, [50, 87, 0], atol=1e-6)
    np.testing.assert_allclose(hi, [200, 123, 2], atol=1e-6)
    assert m.measures.sum() == pytest.approx(150 * 36 * 2 - np.pi * 9 * 2, rel=2e-3)


def test_rotated_part_is_refused_unless_the_transform_is_given(specimen_stl):
    rotated = shapely.affinity.rotate(BED_OUTLINE, 90, origin=(125, 105))
    with pytest.raises(
        GeometryError,
        match=r"does not match the G-code's first layer: footprint 150\.0 x 36\.0 mm vs first layer "
        r"36\.0 x 150\.0 mm.*give the transform explicitly",
    ):
        place_stl(specimen_stl, rotated)
    T = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 0, 1])
    T[:3, 3] = [125, 105, -5]
    assert np.array_equal(place_stl(specimen_stl, rotated, transform=T), T)


def test_open_stl_is_refused(tmp_path):
    tri = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]])
    tri.export(tmp_path / "open.stl")
    with pytest.raises(MeshingError, match=r"is not closed \(watertight\); repair it"):
        place_stl(tmp_path / "open.stl", box(0, 0, 1, 1))


def test_analysis_on_the_stl_model(specimen_stl):
    import loadpath.loadcase as lc
    from loadpath.fea import analyze
    from loadpath.mesh import MeshSize

    case = lc.parse(
        'version = 1\n[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 0.5 }\n'
        'fix = ["x", "y", "z"]\n'
        '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 0.5 }\nforce = [1000.0, 0.0, 0.0]\n'
    )
    body = lc.Body.from_layers("specimen", [(0.2 * i, 0.2 * (i + 1), BED_OUTLINE) for i in range(10)])
    (rb,) = lc.resolve(case, [body])
    assert rb.analysis == "2d"
    a = analyze(rb, size=MeshSize(6.0, 1.5, 3.0), model=specimen_stl)
    assert a.resolved.analysis == "3d" and a.mesh.cell_type == "tet10"
    np.testing.assert_allclose(a.result.reactions.sum(axis=0), [-1000.0, 0.0, 0.0], atol=1e-6)
    # the stress at the hole of this coarse 3D mesh is already near the 3D value (3.2, benchmarks.md §4)
    f = a.field(1.0)
    kt = f.tensor(np.array([[125.0, 108.0 + 1e-6]]))[0, 0] / (1000.0 / 72.0)
    assert 2.8 < kt < 3.5
