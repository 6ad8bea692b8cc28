"""Loads and supports on the mesh: resultants, bearing distribution, reactions, rigid-body detection."""

from __future__ import annotations

import loadpath.loadcase as lc
import numpy as np
import pytest
from fea_cases import open_hole_body
from loadpath.errors import LoadCaseError
from loadpath.fea import analyze, facets_of, load_vector, pick
from loadpath.mesh import MeshSize
from shapely.geometry import Point, box

PLATE = box(0, 0, 60, 20).difference(Point(45, 10).buffer(4, quad_segs=16))
CLAMP = '[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 2.0 }\nfix = ["x", "y", "z"]\n'


def _body(outline=PLATE, layers=((0.0, 3.0),)):
    return lc.Body.from_layers("plate", [(a, b, outline) for a, b in layers])


def _solve(loads: str, analysis: str = "2d", supports: str = CLAMP, body=None):
    case = lc.parse("version = 1\n" + supports + loads, "case.toml")
    (rb,) = lc.resolve(case, [body or _body()], analysis=analysis)
    return rb, analyze(rb, size=MeshSize(4.0, 1.2, 2.0))


@pytest.mark.parametrize("analysis", ["2d", "3d"])
def test_force_is_a_uniform_traction_with_the_given_resultant(analysis):
    rb, a = _solve(
        '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 5.0 }\nforce = [120.0, -30.0, 0.0]\n',
        analysis,
    )
    d = a.mesh.dim
    f = load_vector(a.mesh, a.facets, a.picked["pull"], rb.loads[0][0]).reshape(-1, d)
    np.testing.assert_allclose(f.sum(axis=0)[:2], [120.0, -30.0], rtol=1e-12)
    # traction: the force on a facet is proportional to its area
    per_area = 120.0 / a.facets.area[a.picked["pull"]].sum()
    idx = np.flatnonzero(a.picked["pull"])
    fx_facet = a.facets.shape_integral[idx].sum(axis=1) * per_area
    np.testing.assert_allclose(fx_facet, a.facets.area[idx] * per_area)
    # equilibrium: reactions balance the load
    np.testing.assert_allclose(a.result.reactions.sum(axis=0)[:2], [-120.0, 30.0], atol=1e-6)


def test_same_resultant_in_2d_and_3d():
    loads = '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 5.0 }\nforce = [120.0, 0.0, 0.0]\n'
    _, a2 = _solve(loads, "2d")
    _, a3 = _solve(loads, "3d")
    np.testing.assert_allclose(
        a2.result.reactions.sum(axis=0)[0], a3.result.reactions.sum(axis=0)[0], rtol=1e-8
    )


def test_pressure_acts_normal_to_the_boundary():
    rb, a = _solve('[[loads]]\nname = "p"\nwhere = { side = "x_max", within = 0.0 }\npressure = 2.0\n')
    f = load_vector(a.mesh, a.facets, a.picked["p"], rb.loads[0][0]).reshape(-1, 2)
    np.testing.assert_allclose(f.sum(axis=0), [-2.0 * 20 * 3, 0.0], atol=1e-9)  # pushes on the x_max end: -x
    # inside a closed hole the pressure has no resultant
    rb, a = _solve('[[loads]]\nname = "p"\nwhere = { hole_near = [45, 10], radius = 5 }\npressure = 2.0\n')
    f = load_vector(a.mesh, a.facets, a.picked["p"], rb.loads[0][0]).reshape(-1, 2)
    np.testing.assert_allclose(f.sum(axis=0), [0.0, 0.0], atol=1e-9)
    assert np.abs(f).sum() > 10.0


@pytest.mark.parametrize("analysis", ["2d", "3d"])
def test_bearing_load_presses_on_the_half_of_the_hole_facing_the_force(analysis):
    rb, a = _solve(
        '[[loads]]\nname = "pin"\nwhere = { hole_near = [45, 10], radius = 5 }\nforce = [80.0, 0.0, 0.0]\n',
        analysis,
    )
    d = a.mesh.dim
    f = load_vector(a.mesh, a.facets, a.picked["pin"], rb.loads[0][0]).reshape(-1, d)
    np.testing.assert_allclose(f.sum(axis=0)[:2], [80.0, 0.0], atol=1e-9)
    loaded = np.flatnonzero(np.linalg.norm(f, axis=1) > 1e-12)
    x = a.mesh.points[loaded, 0]
    assert np.all(x >= 45.0 - 1e-9), "load on the far half of the hole"
    # cosine distribution: the largest nodal forces are where the wall faces the force (x = 49)
    strongest = loaded[np.argmax(np.linalg.norm(f[loaded], axis=1))]
    assert a.mesh.points[strongest, 0] > 48.5
    # the pin pushes outwards: every nodal force points away from the centre
    r = a.mesh.points[loaded, :2] - [45, 10]
    assert np.all(np.einsum("ij,ij->i", r, f[loaded, :2]) > 0)


def test_bearing_load_along_the_hole_axis_is_refused():
    with pytest.raises(
        LoadCaseError, match=r"load 'pin' on object 'plate': a bearing load needs a force across the hole"
    ):
        _solve(
            '[[loads]]\nname = "pin"\nwhere = { hole_near = [45, 10], radius = 5 }\n'
            "force = [0.0, 0.0, 50.0]\n",
            "3d",
        )


@pytest.mark.parametrize(
    "supports, analysis, match",
    [
        (
            '[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 0.0 }\nfix = ["x"]\n',
            "2d",
            r"object 'plate' is free to translate along y: the supports \('clamp'\) do not hold it; "
            r"add a support",
        ),
        (
            '[[supports]]\nname = "clamp"\nwhere = { side = "x_min", within = 0.0 }\nfix = ["x", "y"]\n',
            "3d",
            r"free to translate along z: the supports \('clamp'\) do not hold it; "
            r"it is analysed in 3D because requested",
        ),
        (
            '[[supports]]\nname = "pin"\nwhere = { hole_near = [45, 10], radius = 5 }\nfix = ["z"]\n',
            "2d",
            r"free to translate along x and translate along y and rotate about z",
        ),
        (
            '[[supports]]\nname = "rail"\nwhere = { side = "y_min", within = 0.0 }\nfix = ["y"]\n',
            "2d",
            r"free to translate along x: the supports \('rail'\)",
        ),
    ],
)
def test_free_body_is_detected_before_solving(supports, analysis, match):
    loads = '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\nforce = [10.0, 0.0, 0.0]\n'
    with pytest.raises(LoadCaseError, match=match):
        _solve(loads, analysis, supports=supports)


def test_each_island_must_be_held():
    from shapely.geometry import MultiPolygon

    two = MultiPolygon([box(0, 0, 20, 10), box(30, 0, 50, 10)])
    loads = '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\nforce = [10.0, 0.0, 0.0]\n'
    with pytest.raises(
        LoadCaseError, match=r"object 'plate' \(the piece at x 30\.0\.\.50\.0, y 0\.0\.\.10\.0\) is free to"
    ):
        _solve(loads, body=_body(two))


def test_a_piece_hinged_to_the_rest_along_an_edge_must_be_held_on_its_own():
    # two slabs that meet only along the line x = 20, z = 1: the layered mesh shares that edge's nodes
    # but no face, so the loaded slab turns about it (a node-connected count passed it, and the solve
    # met a singular stiffness: a fuzzed Cura file stalled conjugate gradients for over 30 s this way)
    body = lc.Body.from_layers("plate", [(0.0, 1.0, box(0, 0, 20, 10)), (1.0, 2.0, box(20, 0, 40, 10))])
    loads = '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 1.0 }\nforce = [10.0, 0.0, 0.0]\n'
    hinged = (r"object 'plate' \(the piece at x 20\.0\.\.40\.0, y 0\.0\.\.10\.0, z 1\.0\.\.2\.0, "
              r"which meets the rest only at a point or along an edge\) is free to")
    with pytest.raises(LoadCaseError, match=hinged):
        _solve(loads, "3d", body=body)


def test_selection_smaller_than_an_element_still_lands_on_the_mesh():
    # the mesh follows the selector: a 0.3 mm strip of the end is picked exactly
    rb, a = _solve(
        '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 0.3 }\nforce = [10.0, 0.0, 0.0]\n'
    )
    c = a.facets.centroid[a.picked["pull"]]
    assert np.all(c[:, 0] >= 59.7 - 1e-9)
    assert a.facets.area[a.picked["pull"]].sum() == pytest.approx((20 + 2 * 0.3) * 3.0, rel=1e-4)


def test_open_hole_reactions_balance_the_pull():
    case = lc.parse(
        "version = 1\n"
        + CLAMP.replace("within = 2.0", "within = 0.5")
        + '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 0.5 }\nforce = [1000.0, 0.0, 0.0]\n'
    )
    (rb,) = lc.resolve(case, [open_hole_body(64)])
    a = analyze(rb, size=MeshSize(3.0, 0.6, 1.0))
    np.testing.assert_allclose(a.result.reactions.sum(axis=0), [-1000.0, 0.0], atol=1e-6)
    assert pick(a.mesh, facets_of(a.mesh), rb.supports[0][1]).sum() == a.picked["clamp"].sum()
