"""How much the 100 % tension-bar figures depend on which published PLA lamina the card is built from.

Usage::

    python benchmarks/bench_card_sources.py [OUT_DIR] [--clt-only]

The evidence behind ``docs/evidence/tension-bar-band.md``.  For the shipped PLA card and for the
laminae of two other published coupon studies of printed PLA it prints

1. the coupon-level figures of classical laminate theory (``bench_mechanics.laminate_ratios``: in
   plane, no walls): 0 over +-45 in stiffness and in first-ply strength (Tsai-Wu, Tsai-Hill), and
   the shipped card's G12 and S at which those ratios meet the band's edges (1.02, 1.25; 1.15, 2.2);
2. the same comparisons on real PrusaSlicer slices through ``loadpath compare``'s own evaluation
   (``bench_mechanics.rows_for``): the 12 mm tension bar at 100 % (aligned 0 and 90 against
   cross-hatching +-45), the bar at 40 % and the swarm paper's open-hole specimen (Table 2).

The alternative laminae are *not* shipped cards and nothing here is fitted: each is one study's
published constants, put in the place of the PLA card for this run only (``_card_in_place``).  The
compressive strengths, which those studies do not give, keep the shipped card's Xc/Xt and Yc/Yt.

- ``shipped``: ``loadpath.stiffness.cards.PLA_CARD`` (Li, Xu & Fang 2024 elastic; Grant et al. 2021
  strengths).
- ``ferreira``: Ferreira et al., Composites Part B 124 (2017) 88-100, doi
  10.1016/j.compositesb.2017.05.013, Tables 3-5 of the preprint: unidirectional 0 / 90 and +-45
  coupons of neat PLA, 100 %, ASTM D638 and D3518: E1 3376, E2 3125, G12 1092 MPa, nu12 0.331;
  Xt 54.7, Yt 37.1, S12 18.0 MPa (S12 from the +-45 coupon, D3518: half its tensile strength).
- ``gonabadi``: Gonabadi, Yadav & Bull, Int. J. Adv. Manuf. Technol. 111 (2020) 695, doi
  10.1007/s00170-020-06138-4: E1 3500 MPa, nu12 0.35, Xt 55 MPa (D638), in-plane Iosipescu shear
  (ASTM D5379, flat, 0 degrees) G12 1270, S 35 MPa.  It gives no E2 or Yt: E2 keeps the shipped
  card's E2/E1, Yt is Ferreira's.

Both alternatives were read as transcribed in a public research note of 2026-10-03 ("Bead-level
(lamina) properties for G-code-based FE: PLA Basic and PAHT-CF", search index file 70801395794),
which cites the papers' open copies; the papers' own tables were not opened here.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import dataclasses  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "benchmarks"))
import bench_mechanics as bm  # noqa: E402
from loadpath.stiffness import cards  # noqa: E402
from loadpath.stiffness.cards import PLA_CARD, MaterialCard, Strengths  # noqa: E402


def _lamina(E1: float, E2: float, G12: float, nu12: float, Xt: float, Yt: float, S: float) -> MaterialCard:  # noqa: N803
    """The PLA card with one study's lamina (MPa); compressive strengths at the card's Xc/Xt, Yc/Yt."""
    k = PLA_CARD.strength
    elastic = dataclasses.replace(PLA_CARD.elastic, E1=E1, E2=E2, G12=G12, nu12=nu12)
    strength = Strengths(Xt=Xt, Xc=Xt * k.Xc / k.Xt, Yt=Yt, Yc=Yt * k.Yc / k.Yt, S=S)
    return dataclasses.replace(PLA_CARD, elastic=elastic, strength=strength)


LAMINAE: dict[str, MaterialCard] = {
    "shipped": PLA_CARD,
    "ferreira": _lamina(3376.0, 3125.0, 1092.0, 0.331, 54.7, 37.1, 18.0),
    "gonabadi": _lamina(3500.0, 3500.0 * PLA_CARD.elastic.E2 / PLA_CARD.elastic.E1, 1270.0, 0.35, 55.0, 37.1, 35.0),
}


@contextlib.contextmanager
def _card_in_place(card: MaterialCard) -> Iterator[None]:
    """Make ``card`` the card of every PLA file for the duration (the files name filament_type PLA).

    ``compare_files`` takes a card by name only; a benchmark that must not add cards to the package
    swaps the registry entry and puts it back.
    """
    old = cards.CARDS["pla"]
    cards.CARDS["pla"] = card
    try:
        yield
    finally:
        cards.CARDS["pla"] = old


def clt(name: str, card: MaterialCard) -> None:
    lam = bm.laminate_ratios(card)
    e, tw, th = (lam["0"][i] / lam["+-45"][i] for i in range(3))
    g_iso = card.elastic.E1 / (2.0 * (1.0 + card.elastic.nu12))
    print(f"  {name:<9} G12/(E1/(2(1+nu12))) {card.elastic.G12 / g_iso:5.3f}  E_x 0 / +-45 / 90 "
          f"{lam['0'][0]:5.0f} / {lam['+-45'][0]:5.0f} / {lam['90'][0]:5.0f} MPa  Tsai-Wu {lam['0'][1]:4.1f} / "
          f"{lam['+-45'][1]:4.1f} / {lam['90'][1]:4.1f} MPa  0 over +-45: stiffer {e:.3f}, stronger {tw:.3f} "
          f"(Tsai-Hill {th:.3f})")


def edges(card: MaterialCard) -> None:
    """The card's G12 and S at which its coupon ratios meet the band's edges (one constant varied at a time)."""
    from scipy.optimize import brentq

    def stiffer(g12: float) -> float:
        lam = bm.laminate_ratios(dataclasses.replace(card, elastic=dataclasses.replace(card.elastic, G12=g12)))
        return lam["0"][0] / lam["+-45"][0]

    def stronger(s: float, criterion: int) -> float:
        lam = bm.laminate_ratios(dataclasses.replace(card, strength=dataclasses.replace(card.strength, S=s)))
        return lam["0"][criterion] / lam["+-45"][criterion]

    g_iso = card.elastic.E1 / (2.0 * (1.0 + card.elastic.nu12))
    g = [brentq(lambda x, t=t: stiffer(x) - t, 0.2 * g_iso, g_iso) for t in (1.02, 1.25)]
    s_tw = [brentq(lambda x, t=t: stronger(x, 1) - t, 2.0, card.strength.Xt) for t in (1.15, 2.2)]
    s_th = brentq(lambda x: stronger(x, 2) - 1.15, 2.0, card.strength.Xt)
    print(f"  shipped card: stiffer 1.02 / 1.25 at G12 = {g[0]:.0f} / {g[1]:.0f} MPa (card {card.elastic.G12:.0f}); "
          f"stronger 1.15 / 2.2 at S = {s_tw[0]:.1f} / {s_tw[1]:.1f} MPa Tsai-Wu, 1.15 at {s_th:.1f} Tsai-Hill "
          f"(card {card.strength.S:.0f})")


def sliced(name: str, card: MaterialCard, folder: Path) -> None:
    with _card_in_place(card):
        files = {
            "cross": bm.sliced(folder, "bar", "cross100", **{**bm.SOLID, **bm.CROSS}),
            "aligned": bm.sliced(folder, "bar", "aligned100", **{**bm.SOLID, **bm.ALIGNED}),
            "90": bm.sliced(folder, "bar", "across100", **{**bm.SOLID, **bm.ALIGNED, "fill_angle": "90"}),
        }
        rows, res, _ = bm.rows_for(files, bm.BAR_CASE, folder, "bar", bm.GAUGE)
        if res[0].card is not card:
            raise RuntimeError(f"{name}: the files were evaluated with {res[0].card.key}, not this lamina")
        a, s0 = rows["aligned"], res[1].failure_load
        print(f"  {name:<9} bar 100 %: aligned over cross-hatching stiffer {a.relative_stiffness:.3f}, stronger "
              f"{a.relative_failure_load:.3f} (per mass {a.relative_specific_stiffness:.3f} / "
              f"{a.relative_failure_load_per_mass:.3f}); strength over aligned: +-45 {res[0].failure_load / s0:.3f}, "
              f"90 {res[2].failure_load / s0:.3f}")
        sparse = {**bm.SPARSE, "fill_density": "40%"}
        files = {
            "cross": bm.sliced(folder, "bar", "cross40", **{**sparse, **bm.CROSS}),
            "aligned": bm.sliced(folder, "bar", "aligned40", **{**sparse, **bm.ALIGNED}),
        }
        rows, _, _ = bm.rows_for(files, bm.BAR_CASE, folder, "bar40", bm.GAUGE)
        a = rows["aligned"]
        print(f"  {name:<9} bar 40 %: stiffer {a.relative_stiffness:.3f}, stronger {a.relative_failure_load:.3f}")
        files = {
            "cross": bm.sliced(folder, "ohs", "cross100", **{**bm.SOLID, **bm.CROSS}),
            "aligned": bm.sliced(folder, "ohs", "aligned100", **{**bm.SOLID, **bm.ALIGNED}),
        }
        rows, _, _ = bm.rows_for(files, bm.SPECIMEN_CASE, folder, "specimen")
        a = rows["aligned"]
        print(f"  {name:<9} Table 2 open hole: specific modulus {a.relative_specific_stiffness:.3f} (paper "
              f"{bm.PAPER_MODULUS['aligned']:.3f}), specific strength {a.relative_failure_load_per_mass:.3f} "
              f"(paper {bm.PAPER_STRENGTH['aligned']:.3f})")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", nargs="?", help="folder for the slices (default: a temporary one)")
    ap.add_argument("--clt-only", action="store_true", help="laminate theory only, no slicing")
    args = ap.parse_args(argv)
    print("1. coupon level (classical laminate theory, no walls)")
    for name, card in LAMINAE.items():
        clt(name, card)
    edges(PLA_CARD)
    if args.clt_only:
        return
    print("\n2. real slices through loadpath compare's evaluation")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(args.out) if args.out else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for name, card in LAMINAE.items():
            sliced(name, card, folder)


if __name__ == "__main__":
    main()
