"""The density field of new sparse infill (loadpath.density) on closed-form stress fields."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.density import DensityOptions, density_field
from loadpath.errors import SettingsError
from loadpath.field import AnalyticField
from shapely.geometry import box

BEAM = box(0.0, -10.0, 120.0, 10.0)  # 6:1, neutral axis y = 0


def bending(pts):
    """Pure bending: sxx = 10 y MPa, nothing else."""
    return np.column_stack([10.0 * pts[:, 1], np.zeros(len(pts)), np.zeros(len(pts))])


def tension(pts):
    return np.column_stack([np.full(len(pts), 25.0), np.zeros(len(pts)), np.zeros(len(pts))])


@pytest.mark.parametrize("criterion", ["energy", "failure"])
def test_bending_puts_plastic_at_the_fibres(criterion):
    f = AnalyticField(bending, BEAM, scale=100.0)
    d = density_field(f, BEAM, flow_width=0.45, slicer_pitch=0.45 / 0.2, options=DensityOptions(criterion))
    inside = np.isfinite(d.rho)
    assert d.reached and d.mean == pytest.approx(0.2, abs=1e-6)
    assert np.nanmin(d.rho) >= d.rho_min - 1e-12 and np.nanmax(d.rho) <= 1.0
    assert d.rho_min == pytest.approx(0.45 / 8.0)
    # dense at the outer fibres, the minimum at the neutral axis
    outer = d.sample([[60.0, 9.5], [60.0, -9.5]])
    axis = d.sample([[60.0, 0.0]])
    assert np.all(outer > 3 * axis[0])
    assert axis[0] == pytest.approx(np.nanmin(d.rho), rel=0.05)  # smoothed over a pitch: near rho_min
    assert axis[0] < 2 * d.rho_min
    # where not clamped: energy rho ~ e0 ~ y^2, von Mises rho ~ |y| (smoothed over a pitch)
    ys = np.array([4.0, 6.0])
    r = d.sample(np.column_stack([np.full(2, 60.0), ys]))
    # (a Gaussian of width s adds s^2 to y^2: s = the 2.25 mm slicer pitch)
    want = (36.0 + 2.25**2) / (16.0 + 2.25**2) if criterion == "energy" else 6.0 / 4.0
    assert r[1] / r[0] == pytest.approx(want, rel=0.08)
    # pitch is flow width / fill, with units of mm
    assert d.pitch_at([[60.0, 9.5]])[0] == pytest.approx(0.45 / outer[0])
    assert np.array_equal(np.isfinite(d.pitch), inside)


def test_uniform_stress_gives_uniform_density():
    f = AnalyticField(tension, BEAM, scale=25.0)
    d = density_field(f, BEAM, 0.45, 2.25)
    assert np.nanstd(d.rho) < 1e-9 and d.mean == pytest.approx(0.2, abs=1e-9)
    assert d.levels(4) == pytest.approx([2.25])


def test_fill_setting_and_unreachable_targets():
    f = AnalyticField(bending, BEAM, scale=100.0)
    d = density_field(f, BEAM, 0.45, 2.25, DensityOptions(fill=0.4))
    assert d.mean == pytest.approx(0.4, abs=1e-6) and d.reached
    # a fill below the no-sag minimum cannot be met: all at the minimum, flagged
    d = density_field(f, BEAM, 0.45, 2.25, DensityOptions(fill=0.02))
    assert not d.reached and np.nanmax(d.rho) == pytest.approx(0.45 / 8.0)
    u = density_field(f, BEAM, 0.45, 2.25, DensityOptions("uniform"))
    assert np.nanmax(u.rho) == np.nanmin(u.rho)


def test_bad_options_name_the_setting():
    with pytest.raises(SettingsError, match="density = 'stress'"):
        DensityOptions("stress")
    with pytest.raises(SettingsError, match="sparse_fill"):
        DensityOptions(fill=20.0)


def test_zones_split_the_beam_into_bands_that_keep_the_fill():
    from loadpath.engines.zones import zones

    f = AnalyticField(bending, BEAM, scale=100.0)
    d = density_field(f, BEAM, 0.45, 2.25)
    zs = zones(d, BEAM, 6)
    assert 3 <= len(zs) <= 6
    # disjoint, covering the beam
    total = sum(z.region.area for z in zs)
    assert total == pytest.approx(BEAM.area, rel=1e-6)
    import shapely

    assert shapely.union_all([z.region for z in zs]).area == pytest.approx(BEAM.area, rel=1e-6)
    # the plastic of the zones (area / pitch * width) is the field's, within 2 %
    fill = sum(z.region.area * 0.45 / z.pitch for z in zs) / BEAM.area
    assert fill == pytest.approx(0.2, rel=0.02)
    # bands: the densest zone holds the outer fibres, the sparsest the neutral axis
    dense, sparse = min(zs, key=lambda z: z.pitch), max(zs, key=lambda z: z.pitch)
    assert dense.region.contains(shapely.Point(60, 9.8)) and sparse.region.contains(shapely.Point(60, 0))
    assert zones(density_field(AnalyticField(tension, BEAM, 25.0), BEAM, 0.45, 2.25), BEAM)[0].region is BEAM


def test_rotated_field_turns_the_directions_and_keeps_the_magnitudes():
    from loadpath.field import RotatedField

    f = AnalyticField(lambda p: np.tile([30.0, -10.0, 5.0], (len(p), 1)), scale=30.0)
    pts = np.array([[0.0, 0.0], [3.0, 4.0]])
    a = f.sample(pts)
    for turn in (np.radians(30.0), -np.radians(30.0)):
        b = RotatedField(f, turn).sample(pts)
        assert b.magnitude == pytest.approx(a.magnitude) and b.anisotropy == pytest.approx(a.anisotropy)
        ang = np.arctan2(b.direction[:, 1], b.direction[:, 0])
        ang = ang - np.arctan2(a.direction[:, 1], a.direction[:, 0])
        assert np.cos(2 * (ang - turn)) == pytest.approx(1.0)


def test_stack_leaves_to_the_skins_what_they_hold():
    # rho = c |sigma| - a / (1 - a): with a solid share a the low-stress band stays at the minimum
    # and the rest is affine in |y| (smoothed over a pitch), at the same mean
    f = AnalyticField(bending, BEAM, scale=100.0)
    bare = density_field(f, BEAM, 0.45, 2.25, DensityOptions("stack"))
    skins = density_field(f, BEAM, 0.45, 2.25, DensityOptions("stack", solid_share=0.3))
    for d in (bare, skins):
        assert d.reached and d.mean == pytest.approx(0.2, abs=1e-6)
    lo = skins.sample(np.column_stack([np.full(3, 60.0), [0.0, 2.0, 4.0]]))
    assert lo == pytest.approx(np.full(3, skins.rho_min))
    off = 0.3 / 0.7
    r = skins.sample([[60.0, 6.0], [60.0, 8.0]])
    assert (r[1] + off) / (r[0] + off) == pytest.approx(8.0 / 6.0, rel=0.08)
    # without skins: rho ~ |sigma| (the failure criterion's law), less contrast than the energy's
    r = bare.sample([[60.0, 4.0], [60.0, 6.0]])
    assert r[1] / r[0] == pytest.approx(6.0 / 4.0, rel=0.08)
    assert np.nanmax(skins.rho) > np.nanmax(bare.rho)


def test_stack_families_share_the_plastic_as_the_principal_stresses_ask():
    f = AnalyticField(bending, BEAM, scale=100.0)  # uniaxial: the minor family has nothing to carry
    major = density_field(f, BEAM, 0.45, 2.25, DensityOptions("stack", family="major"))
    minor = density_field(f, BEAM, 0.45, 2.25, DensityOptions("stack", family="minor"))
    assert minor.mean == pytest.approx(minor.rho_min, rel=1e-6)
    assert major.mean + minor.mean == pytest.approx(0.4, abs=1e-6)

    def shear(pts):  # pure shear: sigma_major = -sigma_minor, both families alike
        return np.column_stack([np.zeros(len(pts)), np.zeros(len(pts)), np.full(len(pts), 20.0)])

    g = AnalyticField(shear, BEAM, scale=20.0)
    a = density_field(g, BEAM, 0.45, 2.25, DensityOptions("stack", family="major", solid_share=0.3))
    b = density_field(g, BEAM, 0.45, 2.25, DensityOptions("stack", family="minor", solid_share=0.3))
    assert a.mean == pytest.approx(0.2, abs=1e-6) and b.mean == pytest.approx(0.2, abs=1e-6)
    with pytest.raises(SettingsError, match="family"):
        DensityOptions("stack", family="sigma3")
    with pytest.raises(SettingsError, match="solid share"):
        DensityOptions("stack", solid_share=1.0)
