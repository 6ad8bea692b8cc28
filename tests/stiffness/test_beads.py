"""The bead model, the cards and the failure criterion against closed forms (issue 14).

- Neck fusion: PrusaSlicer's solid spacing (centre lines one flow width apart) is the card's
  reference (fully fused); a gap wider than the rounded flanks leaves none.
- Straight beads at the solid spacing give the card's stiffness (the bead model reduces to the
  material set directly, up to the transfer at the ends); beads two widths apart lose their
  transverse stiffness but keep ``v E1`` along.
- Tsai-Wu's load factor reproduces each strength in its own uniaxial state.
- Cards: every number has a source; the file's filament type picks the card; the load case can name it.
"""

from __future__ import annotations

import numpy as np
import pytest
from loadpath import loadcase
from loadpath.errors import LoadCaseError, SettingsError
from loadpath.fea.orthotropic import BEADS, LINEAR
from loadpath.gcode.flavors import Role
from loadpath.stiffness import Deposits, from_toolpaths, material_matrices, sample_deposits
from loadpath.stiffness.beads import attributes, bead_state, neck_fraction, subdivide
from loadpath.stiffness.cards import ABS_CARD, CARDS, PETG_CARD, PLA_CARD, card, card_for
from loadpath.stiffness.strength import tsai_wu_factor
from loadpath.toolpath import Path as ToolPath
from meshes import rectangle_tri6

H = 0.2


def test_neck_fraction_is_one_at_the_slicers_solid_spacing_and_zero_past_the_flanks():
    w = np.array([0.45])
    assert neck_fraction(np.array([0.45]), w, w, np.array([H]))[0] == pytest.approx(1.0)
    stadium = 0.45 + H * (1 - np.pi / 4)
    assert neck_fraction(np.array([stadium + 0.01]), w, w, np.array([H]))[0] == 0.0
    d = np.linspace(0.3, 0.6, 31)
    phi = neck_fraction(d, np.full_like(d, 0.45), np.full_like(d, 0.45), np.full_like(d, H))
    assert np.all(np.diff(phi) <= 1e-12) and phi[0] == 1.0 and phi[-1] == 0.0


def lines_deposits(pitch: float, width: float, length: float = 20.0, height: float = 4.0, layers: int = 3):
    """Parallel lines along x across a length x height rectangle, each its own run."""
    ys = np.arange(pitch / 2, height, pitch)
    parts = []
    for k in range(layers):
        paths = [ToolPath(np.array([[0.0, y], [length, y]]), np.full(2, width)) for y in ys]
        dep = from_toolpaths(paths, z_top=(k + 1) * H, height=H, layer=k)
        parts.append(dep)
    return Deposits.concat(parts)


def test_fused_lines_give_the_card_and_spaced_lines_lose_the_transverse_stiffness():
    mat = PLA_CARD.elastic
    mesh = rectangle_tri6(20.0, 4.0, 20, 4, thickness=3 * H)
    for pitch, fused in ((0.45, True), (0.9, False)):
        dep = lines_deposits(pitch, 0.45)
        st = bead_state(subdivide(dep), mat.E1, mat.G12)
        inner = (dep.start[:, 1] > 0.5) & (dep.start[:, 1] < 3.5)
        pieces = subdivide(dep)
        inner_p = (pieces.start[:, 1] > 0.5) & (pieces.start[:, 1] < 3.5)
        assert np.median(st.fused[inner_p]) == pytest.approx(1.0 if fused else 0.0, abs=1e-9), pitch
        assert inner.any()
        pieces, attrs = attributes(dep, mat.E1, mat.G12)
        fields = sample_deposits(mesh, pieces, 0.05, attrs)
        Db = material_matrices(fields, mat, BEADS, 2)
        Dl = material_matrices(sample_deposits(mesh, dep, 0.05), mat, LINEAR, 2)
        c = np.abs(mesh.points[mesh.cells[:, :3]].mean(axis=1) - [10.0, 2.0])
        mid = (c[:, 0] < 8) & (c[:, 1] < 1.0)  # away from the line ends and the outer lines
        if fused:
            np.testing.assert_allclose(Db[mid], Dl[mid], rtol=0.03, atol=1.0)
        else:
            v = fields.effective_fill()[:, mid].mean()
            assert Db[mid, 0, 0].mean() == pytest.approx(v * mat.E1, rel=0.03)
            assert Db[mid, 1, 1].mean() < 0.01 * Dl[mid, 1, 1].mean()


def test_bead_ends_carry_less_within_a_transfer_length():
    mat = PLA_CARD.elastic
    paths = [ToolPath(np.array([[0.0, y], [L, y]]), np.full(2, 0.45)) for y, L in ((0.225, 3.0), (0.675, 30.0))]
    dep = subdivide(from_toolpaths(paths, z_top=H, height=H, layer=0))
    st = bead_state(dep, mat.E1, mat.G12)
    short = dep.end[:, 0] <= 3.0 + 1e-9
    assert st.transfer[short].mean() < st.transfer[~short].mean()
    long_mid = ~short & (dep.start[:, 0] > 5) & (dep.end[:, 0] < 25)
    assert st.transfer[long_mid].min() > 0.99  # far from the ends: the whole load
    ends = ~short & ((dep.start[:, 0] < 1e-9) | (dep.end[:, 0] > 30 - 1e-9))
    assert st.transfer[ends].max() < 0.8


@pytest.mark.parametrize("c", list(CARDS.values()), ids=list(CARDS))
def test_tsai_wu_reaches_each_strength_in_its_own_uniaxial_state(c):
    k = c.strength
    one = np.array([1.0])
    zero = np.zeros(1)
    assert tsai_wu_factor(one, zero, zero, c)[0][0] == pytest.approx(k.Xt)
    assert tsai_wu_factor(-one, zero, zero, c)[0][0] == pytest.approx(k.Xc)
    assert tsai_wu_factor(zero, one, zero, c)[0][0] == pytest.approx(k.Yt)
    assert tsai_wu_factor(zero, -one, zero, c)[0][0] == pytest.approx(k.Yc)
    assert tsai_wu_factor(zero, zero, one, c)[0][0] == pytest.approx(k.S)
    lam, _ = tsai_wu_factor(3 * one, zero, zero, c)
    assert lam[0] == pytest.approx(k.Xt / 3)  # linear in the load


def test_every_card_number_has_a_source_and_the_file_picks_its_card():
    for c in CARDS.values():
        for key in ("E1", "E2", "G12", "nu12", "Xt", "Xc", "Yt", "Yc", "S", "density"):
            assert c.sources.get(key), (c.key, key)
        assert c.key in c.citation()
    assert card_for({"filament_type": "PETG"})[0] is PETG_CARD
    assert card_for({"filament_type": "ABS;PLA"})[0] is ABS_CARD  # the first extruder's
    assert card_for({"material_type": "PLA"})[0] is PLA_CARD
    assert card_for({"EXTRUDER_TRAIN.0.MATERIAL.GUID": "60636bb4-518f-42e7-8237-fe77b194ebe0"})[0] is ABS_CARD
    assert card_for({})[1].startswith("default")
    assert card_for({"filament_type": "PLA"}, named="petg")[0] is PETG_CARD
    with pytest.raises(SettingsError, match="use one of pla, petg, abs"):
        card("nylon")


def test_the_load_case_names_the_card(tmp_path):
    base = '[[supports]]\nwhere = { side = "x_min", within = 1.0 }\nfix = ["x", "y", "z"]\n'
    base += '[[loads]]\nwhere = { side = "x_max", within = 1.0 }\nforce = [1.0, 0.0, 0.0]\n'
    p = tmp_path / "c.toml"
    p.write_text('version = 1\n[material]\nprinted = "PETG"\n' + base)
    assert loadcase.read(p).material.printed == "petg"
    p.write_text('version = 1\n[material]\nprinted = "wood"\n' + base)
    with pytest.raises(LoadCaseError, match='use "pla", "petg" or "abs"'):
        loadcase.read(p)


def test_a_bead_touching_a_wall_end_on_is_fused_to_it():
    """Infill at 45 degrees ending on a perimeter: the perimeter's inner side is fused by the ends."""
    mat = PLA_CARD.elastic
    wall = [ToolPath(np.array([[0.0, 0.225], [20.0, 0.225]]), np.full(2, 0.45)),
            ToolPath(np.array([[0.0, 0.0 - 0.225], [20.0, -0.225]]), np.full(2, 0.45))]
    s = 0.45 * np.sqrt(2)
    infill = [ToolPath(np.array([[x, 0.45], [x + 3.0, 3.45]]), np.full(2, 0.45)) for x in np.arange(0, 17, s)]
    dep = subdivide(Deposits.concat([
        from_toolpaths(wall, z_top=H, height=H, layer=0, role=Role.PERIMETER),
        from_toolpaths(infill, z_top=H, height=H, layer=0),
    ]))
    st = bead_state(dep, mat.E1, mat.G12)
    inner_wall = (np.abs(dep.start[:, 1] - 0.225) < 1e-9) & (dep.start[:, 0] > 2) & (dep.end[:, 0] < 16)
    assert np.median(st.fused[inner_wall]) > 0.9
