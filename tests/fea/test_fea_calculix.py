"""Cross-check against CalculiX (ccx 2.20): same mesh, same supports, same loads, independent solver.

The decks are written here from our load case: the mesh as CPS6 (plane stress, the open-hole specimen
of benchmarks.md §4) or C3D10 (a stepped 3D part), the supports as node sets, forces as our consistent
nodal forces (*CLOAD) and pressures as CalculiX's own face loads (*DLOAD), so the pressure integration
is checked independently. CalculiX must really run (``require_tool("ccx")``).
"""

from __future__ import annotations

import ccx_io
import loadpath.loadcase as lc
import numpy as np
import pytest
from conftest import require_tool
from fea_cases import OPEN_HOLE_CASE, kt_at_hole, open_hole_body
from loadpath.fea import analyze, load_vector
from loadpath.field import principal_stresses
from loadpath.mesh import MeshSize
from shapely.geometry import Point, box

pytestmark = [pytest.mark.slow, pytest.mark.real_tool("ccx")]


def _compare(a, ccx_u, ccx_s):
    """L2 displacement error, and the largest principal-direction difference (degrees) where the
    in-plane anisotropy exceeds 10 % of its maximum."""
    d = a.mesh.dim
    l2 = np.linalg.norm(a.result.u - ccx_u[:, :d]) / np.linalg.norm(ccx_u[:, :d])
    ip = [0, 1, 2] if d == 2 else [0, 1, 5]
    s1, s2, e_ccx, _ = principal_stresses(ccx_s[:, ip])
    _, _, e_ours, _ = principal_stresses(a.result.stress[:, ip])
    aniso = s1 - s2
    strong = aniso > 0.1 * aniso.max()
    angle = np.degrees(np.arccos(np.clip(np.abs(np.sum(e_ccx * e_ours, axis=1)), 0.0, 1.0)))
    return float(l2), float(angle[strong].max()), int(strong.sum())


def test_open_hole_plane_stress_against_calculix_cps6(tmp_path):
    require_tool("ccx")
    (rb,) = lc.resolve(lc.parse(OPEN_HOLE_CASE, "open_hole.toml"), [open_hole_body(80)])
    a = analyze(rb, size=MeshSize(3.0, 0.25, 1.0))
    m = a.mesh
    f = sum(load_vector(m, a.facets, a.picked[ld.name], ld) for ld, _ in rb.loads).reshape(-1, 2)
    clamp = np.unique(a.facets.nodes[a.picked["clamp"]])
    deck = tmp_path / "open_hole.inp"
    ccx_io.write_deck(
        deck, m.points, m.cells, "tri6", 3500.0, 0.35, {"CLAMP": (clamp, (1, 2))}, cload=f, thickness=2.0
    )
    ccx_io.run(deck)
    res = ccx_io.read_frd(deck.with_suffix(".frd"), len(m.points))
    ccx_u, ccx_s = res["DISP"], ccx_io.to_voigt(res["STRESS"], 2)
    assert not np.any(np.isnan(ccx_u)) and not np.any(np.isnan(ccx_s))
    l2, angle, n = _compare(a, ccx_u, ccx_s)
    kt_ours, kt_ccx = kt_at_hole(m.points, a.result.stress), kt_at_hole(m.points, ccx_s)
    assert l2 <= 0.01, f"relative L2 displacement difference {l2:.2e}"
    assert abs(kt_ours / kt_ccx - 1) <= 0.02, f"Kt ours {kt_ours:.4f}, CalculiX {kt_ccx:.4f}"
    assert angle <= 2.0, (
        f"principal directions differ by {angle:.2f} degrees at {n} strongly anisotropic nodes"
    )
    assert n > 0.5 * len(m.points)


def test_stepped_3d_part_against_calculix_c3d10(tmp_path):
    require_tool("ccx")
    case = lc.parse(
        'version = 1\n[[supports]]\nname = "wall"\nwhere = { side = "x_min", within = 0.0 }\n'
        'fix = ["x", "y", "z"]\n'
        '[[loads]]\nname = "pull"\nwhere = { side = "x_max", within = 0.0 }\nforce = [400.0, 0.0, -30.0]\n'
        '[[loads]]\nname = "press"\nwhere = { side = "z_max", within = 0.0 }\npressure = 0.5\n',
        "stepped.toml",
    )
    plate = box(0, 0, 60, 20).difference(Point(40, 10).buffer(4, quad_segs=12))
    body = lc.Body.from_layers("stepped", [(0.0, 3.0, plate), (3.0, 8.0, box(0, 0, 15, 20))])
    (rb,) = lc.resolve(case, [body])
    assert rb.analysis == "3d"
    a = analyze(rb, size=MeshSize(3.0, 1.0, 1.5))
    m = a.mesh
    pull = rb.loads[0][0]
    f = load_vector(m, a.facets, a.picked["pull"], pull).reshape(-1, 3)
    # the pressure as CalculiX face loads on the same element faces
    faces, owner = m.boundary
    dload = []
    for k in np.flatnonzero(a.picked["press"]):
        cell = m.cells[owner[k]]
        local = frozenset(int(np.flatnonzero(cell[:4] == v)[0]) for v in faces[k, :3])
        dload.append((int(owner[k]), ccx_io.TET_FACES[local], 0.5))
    wall = np.unique(a.facets.nodes[a.picked["wall"]])
    deck = tmp_path / "stepped.inp"
    ccx_io.write_deck(
        deck, m.points, m.cells, "tet10", 3500.0, 0.35, {"WALL": (wall, (1, 2, 3))}, cload=f, dload=dload
    )
    ccx_io.run(deck)
    res = ccx_io.read_frd(deck.with_suffix(".frd"), len(m.points))
    ccx_u, ccx_s = res["DISP"], ccx_io.to_voigt(res["STRESS"], 3)
    l2, angle, n = _compare(a, ccx_u, ccx_s)
    p = m.points
    hole = (np.hypot(p[:, 0] - 40, p[:, 1] - 10) < 4.0 + 1e-6) & (p[:, 2] <= 3.0)
    peak_ours, peak_ccx = a.result.stress[hole, 0].max(), ccx_s[hole, 0].max()
    assert l2 <= 0.01, f"relative L2 displacement difference {l2:.2e}"
    assert abs(peak_ours / peak_ccx - 1) <= 0.02, (
        f"peak sxx at the hole: ours {peak_ours:.3f}, CalculiX {peak_ccx:.3f} MPa"
    )
    assert angle <= 2.0, (
        f"principal directions differ by {angle:.2f} degrees at {n} strongly anisotropic nodes"
    )
    # the field the engines sample is the same stress, projected on a layer
    fld = a.field(1.5)
    on_plane = np.isclose(p[:, 2], 1.5)
    if np.any(on_plane):
        np.testing.assert_allclose(
            fld.tensor(p[on_plane, :2]), ccx_s[on_plane][:, [0, 1, 5]], atol=1e-3 * np.abs(ccx_s).max()
        )
