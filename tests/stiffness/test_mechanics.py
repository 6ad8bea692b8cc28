"""Mechanics of real slices (issue 14): the tension bar of the done-when list and paper Table 2.

Real PrusaSlicer 2.5 files (MK3S presets, ``tests/slicing.py``) through ``loadpath compare``'s own
evaluation (bead fill model, the file's card, Tsai-Wu first-ply failure), no parameter fitted to any
of these cases:

- tension bar 100 x 12 x 2 mm, cross-hatching (rectilinear 45 degrees) against aligned
  rectilinear at 0 degrees: at 100 % aligned is stronger by a factor in [1.15, 2.2] and stiffer by
  one in [1.02, 1.25]; at 40 % (no skins) at least 1.3x stiffer and 1.3x stronger;
- the swarm paper's open-hole specimen (Table 2, benchmarks.md §1.4) at 100 %: aligned over
  cross-hatching, specific strength within 10 % of 1.796; the specific modulus (paper 1.117) is
  checked against what coupon cards allow (xfail with the measured figure: see the reason).
- the failure load converges as the mesh is refined (characteristic distance, Whitney-Nuismer);
- coupon validation: the bar at 100 % in four raster layups (0, +-45, 0/90, 90) against published
  PLA tensile tests (orderings pass; Letcher & Waytashek's ratios are a strict xfail with the figures);
  the ASTM D638 dogbone and the pattern data set are in ``benchmarks/bench_coupons.py``.

The load cases hold one end face in x (y at its middle) and pull the other, so the part contracts
freely; ``benchmarks/bench_mechanics.py`` has the same cases and prints every figure.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
import slicing
import trimesh
from loadpath import loadcase, stiffness

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import bench_mechanics as bench  # noqa: E402


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("mechanics")


def _case(folder: Path, text: str, name: str):
    p = folder / f"{name}.toml"
    p.write_text(text)
    return loadcase.read(p)


def _compare(folder: Path, files: list[Path], text: str, name: str, gauge=None):
    rows, results, _ = bench.rows_for(dict(zip("ab", files, strict=True)), text, folder, name, gauge)
    return list(rows.values()), results


RASTER = {
    "cross-hatching": bench.CROSS,  # rectilinear 45: +-45 alternating
    "aligned": bench.ALIGNED,  # alignedrectilinear 0: every layer along the bar
    "0/90": bench.GRID0,  # rectilinear 0: 0 and 90 alternating
    "90": {**bench.ALIGNED, "fill_angle": "90"},  # every layer across the bar
}


@pytest.fixture(scope="module")
def bar100(folder):
    """The tension bar at 100 % in four raster layups, predicted together (cross-hatching first)."""
    files = {}
    for i, (k, v) in enumerate(RASTER.items()):
        files[k] = bench.sliced(folder, "bar", f"r{i}_100", **{**bench.SOLID, **v})
    rows, results, _ = bench.rows_for(files, bench.BAR_CASE, folder, "bar", bench.GAUGE)
    return rows, dict(zip(files, results, strict=True))


@pytest.mark.xfail(
    strict=True,
    reason="measured at 100 %: aligned 1.015x stiffer and 1.121x stronger (1.037x / 1.145x per mass: the "
    "aligned file has 2 % less plastic). The PLA card itself caps it: by laminate theory a fused +-45 coupon "
    "of the card is 1.019x softer and 1.128x weaker (Tsai-Wu; Tsai-Hill 1.097x) than 0 degrees, and a 25 mm "
    "bar gives 1.023x / 1.122x, so the walls are not what holds it down. Published coupons straddle the "
    "band's lower edges: 0 over +-45 strength 0.91 (Letcher & Waytashek 2014), 0.89 (Song et al. 2017, 45 "
    "off-axis), 1.52 (Ferreira et al. 2017); which side the model falls on is set by the card's G12 and S "
    "alone (a Ferreira lamina gives 1.103x / 1.714x, a Gonabadi 2020 one 1.019x / 1.108x): "
    "docs/evidence/tension-bar-band.md, benchmarks/bench_card_sources.py",
)
def test_tension_bar_at_100_percent_aligned_against_cross_hatching(bar100):
    assert trimesh  # the bar STL is built by bench.part_stl with trimesh
    rows, results = bar100
    ref = results["cross-hatching"]
    assert ref.card.key == "pla" and ref.card_why.startswith("filament_type")
    cross, aligned = rows["cross-hatching"], rows["aligned"]
    assert cross.failure_location is not None and cross.safety_factor > 0
    assert 1.02 <= aligned.relative_stiffness <= 1.25, aligned
    assert 1.15 <= aligned.relative_failure_load <= 2.2, aligned


def test_coupon_raster_orderings_against_published(bar100):
    """Strength by raster layup at 100 % against published PLA tensile tests (orderings; ratios xfail below).

    Sources (abstracts read; means only, no scatter published there):

    - Letcher & Waytashek, Proc. ASME IMECE 2014, paper IMECE2014-39379, abstract: ASTM D638, raster
      0 / 45 / 90 degrees: UTS 58 / 64 / 54 MPa (0 stronger than 90).
    - Naveed, Polymers 13(9) (2021) 1487, abstract: PLA and tough PLA at +-45 stronger than at 0/90.
    - Ramirez-Prieto, Martinez-Yanez, Gonzalez-Hernandez, AIMS Materials Science 2025,
      doi 10.3934/matersci.2025019, abstract: PLA+ in tension 0/0 > 0/90 > +-45 (disagrees with
      Naveed on +-45 against 0/90; so do we: first-ply failure of 0/90 is the bond of its 90 plies).

    Predicted (first-ply failure in the gauge length, the PLA card, which comes from other coupons:
    Grant et al. 2021 strengths, Li et al. 2024 elastic): 0/0 > +-45 > 0/90 and 0 > 90, as Naveed and
    as all three sources for 0 against 90 and 0/0 against +-45 (Letcher excepted).  The ASTM D638
    dogbone itself, the ratios and the pattern data set are in ``benchmarks/bench_coupons.py``; this
    test uses the 12 mm tension bar of the done-when list (same layups, a fifth of the cost).
    """
    _, res = bar100
    strength = {k: r.failure_load for k, r in res.items()}
    assert strength["aligned"] > strength["cross-hatching"] > strength["0/90"], strength
    assert strength["aligned"] > strength["90"], strength
    # the first ply to fail in each is the one the layup predicts: along the bead at 0, across it at 90
    assert res["aligned"].weakest.mode == "along" and res["90"].weakest.mode == "across", (
        res["aligned"].weakest.mode, res["90"].weakest.mode)


@pytest.mark.xfail(
    strict=True,
    reason="Letcher & Waytashek 2014 (abstract): +-45 / 0 = 64/58 = 1.103 and 90 / 0 = 54/58 = 0.931; "
    "predicted on the bar 0.89 and 0.62 (dogbone, bench_coupons: 0.899 and 0.616): the card's bond (Grant "
    "et al.: Y_t / X_t = 32/52 = 0.62) is much weaker than Letcher's PLA's (54/58 = 0.93), and no first-ply "
    "criterion makes +-45 stronger than 0 (Letcher's +-45 exceeds even his 0 degree strength)",
)
def test_coupon_raster_ratios_within_10_percent_of_letcher(bar100):
    _, res = bar100
    s0 = res["aligned"].failure_load
    assert abs(res["cross-hatching"].failure_load / s0 / (64.0 / 58.0) - 1) <= 0.10
    assert abs(res["90"].failure_load / s0 / (54.0 / 58.0) - 1) <= 0.10


def test_tension_bar_at_40_percent_aligned_against_cross_hatching(folder):
    """Parallel unfused lines along the load against +-45 lines held together only at crossings."""
    sparse = {**bench.SPARSE, "fill_density": "40%"}
    files = [
        bench.sliced(folder, "bar", "cross40", **{**sparse, **bench.CROSS}),
        bench.sliced(folder, "bar", "aligned40", **{**sparse, **bench.ALIGNED}),
    ]
    (cross, aligned), _ = _compare(folder, files, bench.BAR_CASE, "bar", bench.GAUGE)
    assert aligned.relative_stiffness >= 1.3, aligned
    assert aligned.relative_failure_load >= 1.3, aligned


@pytest.fixture(scope="module")
def specimen(folder):
    files = [
        bench.sliced(folder, "ohs", "cross100", **{**bench.SOLID, **bench.CROSS}),
        bench.sliced(folder, "ohs", "aligned100", **{**bench.SOLID, **bench.ALIGNED}),
    ]
    return _compare(folder, files, bench.SPECIMEN_CASE, "specimen")


@pytest.mark.xfail(
    strict=True,
    reason="measured 1.110 against the paper's 1.796 (-38 %, band +-10 %): in both specimens the first bead to "
    "fail is the wall bead running round the top of the hole (hoop stress along it, the same walls in both "
    "designs); the paper's strength is the ultimate load, reached after the walls crack and the infill "
    "carries the net section: first-ply failure without progressive damage cannot see that",
)
def test_paper_table2_specific_strength_of_aligned_over_cross_hatching(specimen):
    rows, results = specimen
    target = bench.PAPER_STRENGTH["aligned"]
    got = rows[1].relative_failure_load_per_mass
    assert abs(got / target - 1) <= 0.10, (got, target)
    # the open hole is where the aligned specimen fails (not at its ends)
    x, y, _ = rows[1].failure_location
    hole = results[1].predictions[0].analysis.resolved.body
    cx, cy = hole.slabs[0].outline.interiors[0].centroid.coords[0]
    assert ((x - cx) ** 2 + (y - cy) ** 2) ** 0.5 < 6.0, rows[1].failure_location


@pytest.mark.xfail(
    strict=True,
    reason="the fully fused PLA card is nearly isotropic (Li et al. 2024: E2/E1 0.97, G12/E1 0.34), so a "
    "+-45 laminate is only 1.02-1.03x softer than 0 degrees; printed PLA's early nonlinear in-plane shear "
    "(Sabik et al., Mech. Mater. 175 (2022) 104506) would not reach the paper's 1.117 either: at the strains "
    "where modulus is measured a +-45 ply's shear stress is about a tenth of its strength (README, mechanics). "
    "It is the card's G12 that decides: Ferreira et al. 2017's lamina (G12 0.86 of the isotropic value) gives "
    "1.126, Gonabadi et al. 2020's Iosipescu one (0.98) 1.031 (docs/evidence/tension-bar-band.md)",
)
def test_paper_table2_specific_modulus_of_aligned_over_cross_hatching(specimen):
    rows, _ = specimen
    target = bench.PAPER_MODULUS["aligned"]
    got = rows[1].relative_specific_stiffness
    assert abs(got / target - 1) <= 0.05, (got, target)


def test_failure_load_converges_under_mesh_refinement(folder, specimen):
    """Refining the hole's elements from 2 to 1 to 1/2 pitch keeps the failure load within 5 %.

    Measured on the aligned specimen: 1620, 1624, 1558 N (the top of the hole every time).
    The beads are sampled at a third of the finest element (coarser samples leave small elements
    with a handful of points: a noisy fill, not a converging one).  A peak-stress criterion would follow the hole's stress peak as
    it sharpens; the averaged bead stresses do not.
    """
    from loadpath import gcode, geometry
    from loadpath.loadcase.resolve import resolve
    from loadpath.mesh.sizing import MeshSize
    from loadpath.stiffness.cards import PLA_CARD

    path = folder / "ohs_aligned100.gcode"
    program = gcode.read(path)
    geo = geometry.layer_geometry(program, check=False)
    (rb,) = resolve(_case(folder, bench.SPECIMEN_CASE, "specimen"), geo.bodies())
    dep = stiffness.from_program(program, geo.object(rb.name).code)
    loads = []
    for h_min in (0.9, 0.45, 0.225):
        mesh = stiffness.stiffness_mesh(rb, size=MeshSize(3.6, h_min, h_min, 1.3))
        opts = stiffness.StiffnessOptions(resolution=min(0.1, h_min / 3))  # samples finer than the elements
        loads.append(stiffness.assess(rb, dep, PLA_CARD, opts, mesh=mesh).failure_load)
    assert max(abs(v / loads[-1] - 1) for v in loads) <= 0.05, loads
    assert slicing  # real slices only (tests/slicing.py via the benchmark's helpers)
