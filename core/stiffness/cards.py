"""Material cards of printed plastics: the elastic constants and strengths of one fully fused ply.

A :class:`MaterialCard` is what the bead model (:mod:`loadpath.stiffness.beads`) starts from: the ply
of parallel beads at the slicer's solid spacing (PrusaSlicer: flow width = bead pitch), in the bead
axes (1 along the bead, 2 across it in the layer).  Its elastic part is a
:class:`~loadpath.fea.orthotropic.PrintedMaterial`; its strengths feed the Tsai-Wu criterion of
:mod:`loadpath.stiffness.strength`.  Sparse plies, unfused neighbours, crossings and bead ends are
the bead model's business, not the card's: a card holds coupon numbers only.

Every number carries its source (``MaterialCard.sources``).  Where a number could be opened and read
in the session that wrote it the source says ``[read]``; ``[recalled]`` marks numbers transcribed from
memory of the paper (journal, table) and not re-read, so a user can check them; ``[derived]`` marks
a number computed from others by the rule stated.

The card of a file: :func:`card_for` reads the slicer's filament type (PrusaSlicer / OrcaSlicer
``filament_type``, Cura ``material_type`` or the material GUID of its generic PLA/ABS/PETG) and
falls back to PLA; a load case can name one (``[material] printed = "petg"``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from loadpath.errors import SettingsError
from loadpath.fea.orthotropic import ABS_PRINTED, PLA_PRINTED, PrintedMaterial

__all__ = ["Strengths", "MaterialCard", "CARDS", "card", "card_for", "PLA_CARD", "PETG_CARD", "ABS_CARD"]


@dataclass(frozen=True)
class Strengths:
    """Strengths of a fully fused ply in the bead axes, MPa (all positive).

    Attributes
    ----------
    Xt, Xc : float
        Along the bead, in tension and compression.
    Yt, Yc : float
        Across the bead in the layer (the bond between neighbours), tension and compression.
    S : float
        In-plane shear (along the bond).
    """

    Xt: float  # noqa: N815 (the usual symbols)
    Xc: float  # noqa: N815
    Yt: float  # noqa: N815
    Yc: float  # noqa: N815
    S: float  # noqa: N815

    def __post_init__(self) -> None:
        for k in ("Xt", "Xc", "Yt", "Yc", "S"):
            v = getattr(self, k)
            if not v > 0:
                raise SettingsError(f"strength {k} = {v!r} MPa must be positive")


@dataclass(frozen=True)
class MaterialCard:
    """A printed plastic: elastic ply, strengths, and where every number comes from.

    Attributes
    ----------
    key : str
        Short name (``pla``, ``petg``, ``abs``).
    elastic : PrintedMaterial
    strength : Strengths
    sources : dict of str -> str
        Quantity (``E1``, ``Xt``, ...) -> citation with ``[read]`` / ``[recalled]`` / ``[derived]``.
    """

    key: str
    elastic: PrintedMaterial
    strength: Strengths
    sources: dict[str, str] = field(default_factory=dict, compare=False)

    @property
    def name(self) -> str:
        """Display name."""
        return self.elastic.name

    @property
    def density(self) -> float:
        """Solid density, g/cm³."""
        return self.elastic.density

    def citation(self) -> str:
        """One line naming the card and its sources (the footer of ``loadpath compare``)."""
        seen: dict[str, list[str]] = {}
        for k, v in self.sources.items():
            seen.setdefault(v, []).append(k)
        return f"{self.key}: " + "; ".join(f"{', '.join(ks)}: {src}" for src, ks in seen.items())


_LI = (
    "Li, Xu & Fang, Thin-Walled Structures 199 (2024) 111800, printed PLA lamina, as transcribed in "
    "github tomohiron907/Strecs3D FEM/step2inp/MaterialManager.cpp [read]"
)
_GRANT = (
    "Grant, Regez, Kocak, Huber, Mooers, Results in Materials 12 (2021) 100227 (PLA/ABS coupons at "
    "0-90 deg, ASTM D638), as transcribed in a public Hoffman-criterion PLA card (tensile X 52, Y 32; "
    "compressive X 61, Y 47; shear 35 MPa) [read; the compressive and shear values' own test is not "
    "named there]"
)

PLA_CARD = MaterialCard(
    "pla",
    PLA_PRINTED,
    Strengths(Xt=52.0, Xc=61.0, Yt=32.0, Yc=47.0, S=35.0),
    {
        "E1": _LI,
        "E2": _LI,
        "G12": _LI,
        "nu12": _LI,
        "nu23": _LI,
        "Xt": _GRANT,
        "Xc": _GRANT,
        "Yt": _GRANT,
        "Yc": _GRANT,
        "S": _GRANT,
        "density": "Prusament PLA data sheet, 1.24 g/cm3 (the filament_density of PrusaSlicer's preset) [read]",
    },
)
"""Printed PLA.  Replaces the E1 3209 / E2 2899 / G12 1195 MPa attributed to Casavola et al. 2016
from memory, which no session could re-read; Li et al.'s lamina is the one with an openable transcription."""

_BAMBU_PETG = (
    "Bambu Lab PETG Basic technical data sheet V3.0 (ISO 527, X1C, 255 C): E_XY 2780, E_Z 2550 MPa, "
    "tensile strength XY 51, Z 35 MPa [read via a public research note quoting it with its URL]"
)
PETG_CARD = MaterialCard(
    "petg",
    PrintedMaterial(
        "PETG (printed, fully fused ply)",
        E1=2780.0,
        E2=2550.0,
        G12=2780.0 / (2.0 * 1.38),
        nu12=0.38,
        nu23=0.38,
        density=1.27,
        source=_BAMBU_PETG,
    ),
    Strengths(Xt=51.0, Xc=51.0 * 61.0 / 52.0, Yt=35.0, Yc=35.0 * 47.0 / 32.0, S=35.0),
    {
        "E1": _BAMBU_PETG + " (E_XY)",
        "E2": _BAMBU_PETG + " (E_Z as the bond direction)",
        "G12": "[derived] E1 / (2 (1 + 0.38)), isotropic relation (no PETG shear coupon found)",
        "nu12": "[recalled] 0.38, typical for PETG (no printed-PETG Poisson coupon found)",
        "nu23": "[recalled] 0.38, as nu12",
        "Xt": _BAMBU_PETG + " (XY)",
        "Yt": _BAMBU_PETG + " (Z: the bond between layers, taken for the bond between beads)",
        "Xc": "[derived] Xt x 61/52, the compressive/tensile ratio of the PLA card",
        "Yc": "[derived] Yt x 47/32, as the PLA card",
        "S": "[derived] = Yt (the bond carries the shear; no PETG shear coupon found)",
        "density": "1.27 g/cm3, Prusament PETG data sheet [recalled]",
    },
)
"""Printed PETG (data-sheet level: the weakest card, see its sources)."""

_ALAIMO = "Alaimo et al., Composites Part B 113 (2017) 371-380, via Murugan's thesis §3.6 [read in the thesis]"
_AHN = (
    "Ahn, Montero, Odell, Roundy, Wright, Rapid Prototyping J. 8(4) (2002) 248-257, ABS P400 coupons, "
    "tension and compression at 0 and 90 deg [recalled]"
)
ABS_CARD = MaterialCard(
    "abs",
    ABS_PRINTED,
    Strengths(Xt=26.0, Xc=39.0, Yt=14.0, Yc=35.0, S=14.0),
    {
        "E1": _ALAIMO,
        "E2": _ALAIMO,
        "G12": _ALAIMO,
        "nu12": _ALAIMO,
        "Xt": _AHN,
        "Xc": _AHN,
        "Yt": _AHN,
        "Yc": _AHN,
        "S": "[derived] = Yt (shear fails the bond)",
        "density": "1.04 g/cm3, ABS [recalled]",
    },
)
"""Printed ABS of the thesis's MBB experiment."""

CARDS: dict[str, MaterialCard] = {c.key: c for c in (PLA_CARD, PETG_CARD, ABS_CARD)}
"""Cards by key."""

_ALIASES = {"pla": "pla", "pla+": "pla", "petg": "petg", "pet": "petg", "pctg": "petg", "abs": "abs", "asa": "abs"}
_CURA_GUIDS = {
    "506c9f0d-e3aa-4bd4-b2d2-23e2425b1aa9": "pla",  # Generic PLA
    "60636bb4-518f-42e7-8237-fe77b194ebe0": "abs",  # Generic ABS
    "69386c85-5b6c-421a-bec5-aeb1fb33f060": "petg",  # Generic PETG
}


def card(name: str) -> MaterialCard:
    """Return the card named ``pla``, ``petg`` or ``abs`` (case-insensitive, a few aliases).

    Raises
    ------
    SettingsError
        Unknown name (the message lists the cards).
    """
    key = _ALIASES.get(str(name).strip().lower())
    if key is None:
        raise SettingsError(f"material card {name!r} is unknown; use one of {', '.join(CARDS)}")
    return CARDS[key]


def card_for(config: dict[str, str], named: str | None = None) -> tuple[MaterialCard, str]:
    """Choose the card of a file.

    Parameters
    ----------
    config : dict
        ``Program.config`` (the slicer settings embedded in the G-code).
    named : str, optional
        A card named by the user (load case or command line); wins over the file.

    Returns
    -------
    card : MaterialCard
    why : str
        Where the choice came from (``"load case"``, ``"filament_type = PETG"``, ``"default"``).
    """
    if named:
        return card(named), "named"
    for key in ("filament_type", "material_type", "MATERIAL", "material"):
        raw = config.get(key)
        if raw:
            first = str(raw).split(";")[0].split(",")[0].strip().strip('"').lower()
            if first in _ALIASES:
                return CARDS[_ALIASES[first]], f"{key} = {raw.strip()}"
    for key, value in config.items():
        if "guid" in key.lower() and str(value).strip().lower() in _CURA_GUIDS:
            return CARDS[_CURA_GUIDS[str(value).strip().lower()]], f"{key} = {value.strip()}"
    return PLA_CARD, "default (the file names no filament type)"
