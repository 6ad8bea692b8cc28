"""The toolpath options: what a user chooses about the new paths, with types, bounds and conversion.

One owner for the options the load case's ``[toolpath]`` table, the pipeline
(:class:`loadpath.pipeline.PipelineOptions`) and the application's settings
(:mod:`loadpath.plugin.settings`, which adds the machine and run fields, resolves them from the
slicer and generates the command line and the Cura plugin's settings) all speak of:

- :class:`Field` -- one option: name, kind, default, unit, help, choices, bounds, its command-line
  flag, whether the ``[toolpath]`` table may set it;
- :data:`TOOLPATH_FIELDS` -- the toolpath options (engine, pitch, K, principal, replace, bead
  widths, links, volume matching, stagger); :data:`TABLE_KEYS` -- those the ``[toolpath]`` table
  takes;
- :func:`convert` -- a value checked against its field and converted, one line on bad input;
- :func:`user_pitch` -- the one reading of "no pitch": None or 0 means each unit's slicer pitch.

The engine names come from the registry (:data:`loadpath.engines.NAMES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from loadpath import engines
from loadpath.density import CHOICES as DENSITY_CRITERIA
from loadpath.errors import SettingsError

__all__ = [
    "Field",
    "TOOLPATH_FIELDS",
    "TABLE_KEYS",
    "PRINCIPALS",
    "REPLACE_KINDS",
    "field",
    "convert",
    "user_pitch",
]

PRINCIPALS = ("max_abs", "min_abs", "tensile", "compressive", "alternate", "cross")
"""Principal stresses a path can follow (``alternate``: ``max_abs`` and ``min_abs`` by layer;
``cross``: layers at +-``cross_angle`` about ``max_abs``)."""
REPLACE_KINDS = ("solid", "sparse", "top", "bottom")
"""Infill kinds that can be replaced."""


@dataclass(frozen=True)
class Field:
    """One setting in the schema.

    Attributes
    ----------
    name : str
        Attribute of :class:`Settings`.
    kind : {"str", "float", "int", "bool", "kinds", "optional_float"}
    default : Any
    unit : str
    help : str
    choices : tuple of str
        Allowed values (``str`` and ``kinds``).
    minimum, maximum : float or None
        Bounds (inclusive) for numbers.
    cli : str or None
        Command-line flag of its own (``--pitch``); every field is also reachable with ``--set``.
    toolpath : bool
        Allowed in the load case's ``[toolpath]`` table.
    group : {"toolpath", "machine", "run"}
        ``machine`` fields normally come from the slicer.
    help_says_default : bool
        The help itself says what leaving the setting unset does (``--engine``: the level sets, with
        the swarm where they give way, not the stored default), so the CLI adds no "(default X)".
    """

    name: str
    kind: str
    default: Any
    unit: str = ""
    help: str = ""
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    maximum: float | None = None
    cli: str | None = None
    toolpath: bool = False
    group: str = "toolpath"
    help_says_default: bool = False


TOOLPATH_FIELDS: tuple[Field, ...] = (
    Field(
        "engine",
        "str",
        engines.DEFAULT,
        "",
        f"path engine; not set: {engines.SOLID_FIRST}, and {engines.DEFAULT} on solid layers a bending "
        "part's neutral axis cuts where the mechanics model predicts it better; set, it lays every kind",
        engines.NAMES,
        cli="--engine",
        toolpath=True,
        help_says_default=True,
    ),
    Field(
        "sparse_engine",
        "str",
        "auto",
        "",
        f"path engine for sparse infill; auto: the one named by engine, else {engines.SPARSE_DEFAULT}",
        engines.SPARSE_CHOICES,
        toolpath=True,
    ),
    Field(
        "pitch",
        "optional_float",
        None,
        "mm",
        "centre-to-centre distance of the new paths; default: the slicer's pitch for the replaced infill",
        minimum=0.05,
        maximum=50.0,
        cli="--pitch",
        toolpath=True,
        help_says_default=True,
    ),
    Field(
        "K",
        "float",
        5.0,
        "",
        "swarm: weight of stress alignment against even spacing",
        minimum=0.0,
        maximum=1000.0,
        cli="--K",
        toolpath=True,
    ),
    Field(
        "principal",
        "str",
        "max_abs",
        "",
        "principal stress the paths follow ('alternate': sigma1 and sigma2 paths in alternating layers; "
        "'cross': layers at +-cross_angle about the largest principal stress)",
        PRINCIPALS,
        cli="--principal",
        toolpath=True,
    ),
    Field(
        "replace",
        "kinds",
        ("solid",),
        "",
        "infill kinds replaced (comma-separated)",
        REPLACE_KINDS,
        cli="--replace",
        toolpath=True,
    ),
    Field(
        "cross_angle",
        "float",
        30.0,
        "deg",
        "principal = cross: layers turned this much either way from the largest principal stress",
        minimum=0.0,
        maximum=90.0,
    ),
    Field(
        "density",
        "str",
        "auto",
        "",
        "where replaced sparse infill puts its plastic: 'auto' (lays 'energy' and 'stack', keeps the one "
        "the mechanics model predicts stronger and stiffer), 'energy' (dense where the strain energy is), "
        "'stack' (fully stressed with the skins: the sparse layers take the stress the solid layers leave), "
        "'failure' (fully stressed, von Mises) or 'uniform' (the slicer's)",
        DENSITY_CRITERIA,
        toolpath=True,
    ),
    Field(
        "density_exponent",
        "optional_float",
        None,
        "",
        "fill ~ measure ** exponent; default 1 (energy: strain energy density, failure: von Mises; "
        "stack: 1/2, on the strain energy density, i.e. the principal stress)",
        minimum=0.0,
        maximum=4.0,
    ),
    Field(
        "sparse_fill",
        "optional_float",
        None,
        "fraction",
        "mean fill of the replaced sparse infill (0.25 or 25%); "
        "default the slicer's, so the part keeps its mass",
        minimum=0.01,
        maximum=1.0,
        toolpath=True,
    ),
    Field(
        "density_max_pitch",
        "float",
        8.0,
        "mm",
        "widest pitch of replaced sparse infill (top skins bridge from line to line)",
        minimum=0.5,
        maximum=50.0,
    ),
    Field(
        "tie_spread",
        "float",
        0.06,
        "fraction",
        "two layouts the mechanics model ranks closer than this share of failure load (and 1 % of "
        "stiffness) are a tie, kept by fewer retractions, then by a print time 2 % shorter (density "
        "'auto'; solid layers where the level "
        "sets gave way); 0: the model's rank alone. Default: how far round-off moves the model's "
        "failure load between layouts",
        minimum=0.0,
        maximum=0.5,
    ),
    Field(
        "width_min",
        "float",
        0.6,
        "x nozzle",
        "narrowest bead, as a multiple of the nozzle diameter",
        minimum=0.2,
        maximum=1.0,
    ),
    Field(
        "width_max",
        "float",
        1.6,
        "x nozzle",
        "widest bead, as a multiple of the nozzle diameter",
        minimum=1.0,
        maximum=3.0,
    ),
    Field(
        "link_max",
        "float",
        2.0,
        "pitches",
        "longest printed link between neighbouring path ends",
        minimum=0.0,
        maximum=10.0,
    ),
    Field(
        "match_volume", "bool", True, "", "scale the flow so each block extrudes the volume the slicer did"
    ),
    Field(
        "max_correction",
        "float",
        0.15,
        "",
        "largest relative flow change volume matching may apply",
        minimum=0.0,
        maximum=0.5,
    ),
    Field(
        "stagger",
        "bool",
        True,
        "",
        "every other layer of a run of identical layers lies half a pitch over (laid again by the engine)",
    ),
    Field(
        "link",
        "bool",
        True,
        "",
        "link each layer's paths end to end into continuous runs (hairpins and links along the edge)",
    ),
)
"""The toolpath options, in the order the help lists them."""

_BY_NAME = {f.name: f for f in TOOLPATH_FIELDS}

TABLE_KEYS: tuple[str, ...] = tuple(f.name for f in TOOLPATH_FIELDS if f.toolpath)
"""Keys of the load case's ``[toolpath]`` table."""


def field(name: str) -> Field:
    """Return the toolpath option called ``name``."""
    return _BY_NAME[name]


def user_pitch(value: float | None) -> float | None:
    """Return the user's pitch, or None where None or 0 asks for each unit's slicer pitch."""
    return float(value) if value else None


def convert(f: Field, value: Any, where: str) -> Any:
    """Validate and convert one value of field ``f``.

    Numbers may be given as text (``"0.45"``, ``"20%"``), kinds as a comma-separated string or a
    list; an ``optional_float`` of None, ``""``, ``"none"`` or ``"auto"`` is None.  Anything outside
    the field's type, choices or bounds is a one-line :class:`~loadpath.errors.SettingsError` that
    starts with ``where``.
    """
    try:
        if f.kind == "optional_float" and (
            value is None or str(value).strip().lower() in ("", "none", "auto")
        ):
            return None
        if f.kind in ("float", "optional_float"):
            v = float(str(value).strip().rstrip("%")) / (100.0 if str(value).strip().endswith("%") else 1.0)
            if not math.isfinite(v):
                raise ValueError
        elif f.kind == "int":
            v = int(float(str(value)))
        elif f.kind == "bool":
            v = _bool(value)
        elif f.kind == "kinds":
            items = value.split(",") if isinstance(value, str) else list(value)
            v = tuple(dict.fromkeys(str(x).strip().lower() for x in items if str(x).strip()))
            bad = [x for x in v if x not in f.choices]
            if not v:
                raise SettingsError(f"{where} is empty; name at least one of {', '.join(f.choices)}")
            if bad:
                raise SettingsError(
                    f"{where}: {', '.join(bad)} is not an infill kind; use any of {', '.join(f.choices)}"
                )
            return v
        else:
            v = str(value).strip()
    except (TypeError, ValueError):
        raise SettingsError(
            f"{where} = {value!r} is not a valid {f.kind.replace('optional_', '')}"
            f"{' (' + f.unit + ')' if f.unit else ''}; {f.help}"
        ) from None
    if f.choices and v not in f.choices:
        raise SettingsError(f"{where} = {v!r} is not one of {', '.join(f.choices)}")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        if (f.minimum is not None and v < f.minimum) or (f.maximum is not None and v > f.maximum):
            unit = f" {f.unit}" if f.unit else ""
            raise SettingsError(
                f"{where} = {v:g}{unit} is outside {f.minimum:g}..{f.maximum:g}{unit}"
                + (f" ({f.help})" if f.help else "")
            )
    return v


def _bool(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    s = str(value).strip().lower()
    if s in ("1", "true", "yes", "on"):
        return True
    if s in ("0", "false", "no", "off", ""):
        return False
    raise ValueError(value)
