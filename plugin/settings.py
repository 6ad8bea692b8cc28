"""Settings: one dataclass and its schema, the single source for every front end.

:class:`Settings` holds what a run needs: the toolpath options a user chooses (engine, pitch, K,
principal stress, which infill kinds are replaced, ...) and the machine facts the splicer must match
(flow model, filament, retraction, speeds).  :data:`SCHEMA` describes every field once (type, unit,
default, bounds, help); the command line (:func:`add_cli_options`), the load case's ``[toolpath]``
table and the Cura plugin's settings list (:func:`cura_setting_definitions`) are generated from it.

Where values come from, in rising precedence (:func:`resolve`):

1. built-in defaults (:data:`SCHEMA`);
2. the slicer: PrusaSlicer-family files carry their configuration (``; prusaslicer_config`` block,
   read by the parser), and PrusaSlicer's post-processing hook exports every option as
   ``SLIC3R_<KEY>`` (read case-insensitively; they win over the file's block when present).  Cura's
   saved files and post-processing scripts carry almost no settings, so the Cura plugin passes its
   resolved settings as a JSON file (``--slicer-settings FILE.json``, Cura's own keys, see
   :func:`from_cura_settings`); without it, values are inferred from the file's own moves
   (:func:`infer_from_moves`: travel feedrate, retraction length and speeds, z-hop);
3. the load case's ``[toolpath]`` table (engine, pitch, K, principal, replace);
4. the command line (``--engine``, ``--pitch``, ``--K``, ``--replace``, ... and ``--set KEY=VALUE``
   for any field).

:attr:`Settings.sources` records where each field's value came from, for the report.

(Over 400 lines: :data:`SCHEMA` is one table of every setting, kept in one place on purpose.)
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from loadpath import engines
from loadpath.errors import SettingsError
from loadpath.options import PRINCIPALS, REPLACE_KINDS, TABLE_KEYS, TOOLPATH_FIELDS, Field, convert
from loadpath.plugin.slicers import (
    from_cura_settings,
    from_prusa_config,
    from_slic3r_env,
    infer_from_moves,
    read_cura_settings,
)

__all__ = [
    "Field",
    "SCHEMA",
    "field_json",
    "schema_field",
    "Settings",
    "REPLACE_KINDS",
    "ENGINES",
    "PRINCIPALS",
    "resolve",
    "from_prusa_config",
    "from_slic3r_env",
    "from_cura_settings",
    "read_cura_settings",
    "infer_from_moves",
    "add_cli_options",
    "cli_values",
    "cura_setting_definitions",
    "splice_options",
]

ENGINES = engines.NAMES  # the registry's live list of names (loadpath.engines.registry)


SCHEMA: tuple[Field, ...] = (
    *TOOLPATH_FIELDS,
    # ---------------------------------------------------------------- run
    Field(
        "jobs",
        "int",
        0,
        "",
        "worker processes for the per-layer work (0: one per core, at most 4; --set jobs=N)",
        minimum=0,
        maximum=256,
        group="run",
    ),
    Field(
        "on_failure",
        "str",
        "fail",
        "",
        "on failure: 'fail' (exit non-zero) or 'keep' the slicer's G-code",
        ("fail", "keep"),
        cli="--on-failure",
        group="run",
    ),
    Field("check", "bool", True, "", "re-read the result and check it before writing", group="run"),
    Field(
        "cache",
        "bool",
        True,
        "",
        "reuse stress analyses and paths of earlier runs kept in $LOADPATH_CACHE_DIR or "
        "$XDG_CACHE_HOME/loadpath (--no-cache: neither read nor write it)",
        group="run",
    ),
    # ---------------------------------------------------------------- machine (from the slicer)
    Field(
        "flow_model",
        "str",
        "rounded",
        "",
        "bead cross-section: PrusaSlicer's rounded rectangle or Cura's rectangle",
        ("rounded", "rectangle"),
        group="machine",
    ),
    Field(
        "nozzle_diameter", "float", 0.4, "mm", "nozzle diameter", minimum=0.05, maximum=3.0, group="machine"
    ),
    Field(
        "filament_diameter",
        "float",
        1.75,
        "mm",
        "filament diameter",
        minimum=0.5,
        maximum=5.0,
        group="machine",
    ),
    Field(
        "extrusion_multiplier",
        "float",
        1.0,
        "",
        "extrusion multiplier / material flow",
        minimum=0.1,
        maximum=3.0,
        group="machine",
    ),
    Field("volumetric_e", "bool", False, "", "E words are mm^3 (use_volumetric_e)", group="machine"),
    Field(
        "travel_speed", "float", 150.0, "mm/s", "travel speed", minimum=1.0, maximum=2000.0, group="machine"
    ),
    Field(
        "travel_speed_z",
        "float",
        0.0,
        "mm/s",
        "z-hop speed (0: travel speed)",
        minimum=0.0,
        maximum=500.0,
        group="machine",
    ),
    Field(
        "retract_length", "float", 0.8, "mm", "retraction length", minimum=0.0, maximum=50.0, group="machine"
    ),
    Field(
        "retract_speed",
        "float",
        35.0,
        "mm/s",
        "retraction speed",
        minimum=0.1,
        maximum=500.0,
        group="machine",
    ),
    Field(
        "deretract_speed",
        "float",
        0.0,
        "mm/s",
        "unretraction speed (0: retraction speed)",
        minimum=0.0,
        maximum=500.0,
        group="machine",
    ),
    Field(
        "retract_restart_extra",
        "float",
        0.0,
        "mm",
        "extra filament primed after a retraction",
        minimum=-10.0,
        maximum=10.0,
        group="machine",
    ),
    Field(
        "retract_lift", "float", 0.0, "mm", "z-hop on retraction", minimum=0.0, maximum=10.0, group="machine"
    ),
    Field(
        "retract_before_travel",
        "float",
        1.0,
        "mm",
        "shorter travels inside the region do not retract",
        minimum=0.0,
        maximum=100.0,
        group="machine",
    ),
    Field(
        "only_retract_when_crossing_perimeters",
        "bool",
        False,
        "",
        "travels inside the region never retract",
        group="machine",
    ),
    Field("wipe", "bool", False, "", "wipe while retracting", group="machine"),
    Field(
        "retract_before_wipe",
        "float",
        0.0,
        "",
        "part of the retraction done before the wipe (0..1)",
        minimum=0.0,
        maximum=1.0,
        group="machine",
    ),
    Field(
        "avoid_crossing_perimeters",
        "bool",
        False,
        "",
        "route travels inside the region instead of across the perimeters (Cura: combing)",
        group="machine",
    ),
    Field("use_firmware_retraction", "bool", False, "", "G10/G11 retraction", group="machine"),
    Field(
        "max_volumetric_speed",
        "float",
        0.0,
        "mm^3/s",
        "volumetric flow limit (0: none)",
        minimum=0.0,
        maximum=1000.0,
        group="machine",
    ),
)


def field_json(f: Field) -> dict[str, Any]:
    """Return a schema field as JSON (what ``GET /v1/schema`` and the load-case editor show)."""
    return {
        "type": f.kind,
        "default": list(f.default) if isinstance(f.default, tuple) else f.default,
        "unit": f.unit,
        "help": f.help,
        "choices": list(f.choices),
        "minimum": f.minimum,
        "maximum": f.maximum,
        "group": f.group,
    }
_FIELDS = {f.name: f for f in SCHEMA}


def schema_field(name: str) -> Field:
    """The :data:`SCHEMA` field called ``name`` (its type, unit and bounds)."""
    return _FIELDS[name]


@dataclass(frozen=True)
class Settings:
    """Every setting of a run, with where each value came from (see the module docstring).

    The attributes are the :data:`SCHEMA` fields (units there); ``sources`` maps a field name to
    ``"default"``, ``"slicer config"``, ``"SLIC3R_* environment"``, ``"Cura settings"``,
    ``"inferred from the G-code"``, ``"load case"`` or ``"command line"``.
    """

    engine: str = engines.DEFAULT
    sparse_engine: str = "auto"
    pitch: float | None = None
    K: float = 5.0  # noqa: N815 (the paper's symbol)
    principal: str = "max_abs"
    replace: tuple[str, ...] = ("solid",)
    cross_angle: float = 30.0
    density: str = "auto"
    density_exponent: float | None = None
    sparse_fill: float | None = None
    density_max_pitch: float = 8.0
    tie_spread: float = 0.06
    width_min: float = 0.6
    width_max: float = 1.6
    link_max: float = 2.0
    match_volume: bool = True
    max_correction: float = 0.15
    stagger: bool = True
    link: bool = True
    jobs: int = 0
    on_failure: str = "fail"
    check: bool = True
    cache: bool = True
    flow_model: str = "rounded"
    nozzle_diameter: float = 0.4
    filament_diameter: float = 1.75
    extrusion_multiplier: float = 1.0
    volumetric_e: bool = False
    travel_speed: float = 150.0
    travel_speed_z: float = 0.0
    retract_length: float = 0.8
    retract_speed: float = 35.0
    deretract_speed: float = 0.0
    retract_restart_extra: float = 0.0
    retract_lift: float = 0.0
    retract_before_travel: float = 1.0
    only_retract_when_crossing_perimeters: bool = False
    wipe: bool = False
    retract_before_wipe: float = 0.0
    avoid_crossing_perimeters: bool = False
    use_firmware_retraction: bool = False
    max_volumetric_speed: float = 0.0
    sources: Mapping[str, str] = field(default_factory=dict, compare=False)

    def with_values(self, values: Mapping[str, Any], source: str) -> Settings:
        """Return a copy with ``values`` (validated) applied, recording ``source`` for each."""
        unknown = sorted(set(values) - set(_FIELDS))
        if unknown:
            import difflib

            near = [m for k in unknown for m in difflib.get_close_matches(k, _FIELDS, 1)]
            hint = f"did you mean {', '.join(near)}? " if near else ""
            raise SettingsError(
                f"unknown setting(s) {', '.join(unknown)} ({source}); {hint}known: {', '.join(_FIELDS)}"
            )
        clean = {k: _convert(_FIELDS[k], v, source) for k, v in values.items() if v is not None}
        src = dict(self.sources)
        src.update({k: source for k in clean})
        return dataclasses.replace(self, **clean, sources=src)

    def source(self, name: str) -> str:
        """Where the value of ``name`` came from."""
        return self.sources.get(name, "default")

    def engine_first_on_solid(self) -> tuple[str, dict[str, Any]] | None:
        """The engine tried first on solid infill (:func:`loadpath.engines.first_on_solid`)."""
        return engines.first_on_solid(self.source("engine") != "default")

    def engine_for_sparse(self) -> str:
        """The engine that lays sparse infill (``sparse_engine``; :func:`loadpath.engines.for_sparse`)."""
        return engines.for_sparse(self.sparse_engine, self.engine, self.source("engine") != "default")

    def as_dict(self) -> dict[str, Any]:
        """Return the values as plain JSON-able data."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in SCHEMA}


def _convert(f: Field, value: Any, source: str) -> Any:
    """Validate and convert one value of field ``f`` (:func:`loadpath.options.convert`)."""
    return convert(f, value, f"{f.name} ({source})")


# ---------------------------------------------------------------------------------------------- resolving


def resolve(
    program=None,
    *,
    env: Mapping[str, str] | None = None,
    cura_settings: Mapping[str, Any] | None = None,
    toolpath=None,
    cli: Mapping[str, Any] | None = None,
) -> Settings:
    """Resolve the settings in rising precedence: defaults < slicer < load case ``[toolpath]`` < command line.

    Parameters
    ----------
    program : loadpath.gcode.Program, optional
        The G-code: its config block (PrusaSlicer family) or, for files without one, its moves.
    env : mapping, optional
        Environment to read ``SLIC3R_*`` from (default: none; pass ``os.environ`` in the hook).
    cura_settings : mapping, optional
        Cura's resolved settings (:func:`read_cura_settings`).
    toolpath : loadpath.loadcase.ToolpathOptions, optional
    cli : mapping of field -> value, optional
        Values given on the command line (None = not given).
    """
    s = Settings()
    if program is not None:
        s = s.with_values(infer_from_moves(program), "inferred from the G-code")
        if program.dialect.family == "cura":
            s = s.with_values({"flow_model": "rectangle", "wipe": False}, "inferred from the G-code")
        if program.config:
            s = s.with_values(from_prusa_config(program.config), "slicer config")
    slic3r = from_slic3r_env(env) if env is not None else {}
    if slic3r:
        s = s.with_values(from_prusa_config(slic3r), "SLIC3R_* environment")
    if cura_settings:
        s = s.with_values(from_cura_settings(cura_settings), "Cura settings")
    if toolpath is not None:
        vals = {k: getattr(toolpath, k) for k in TABLE_KEYS}
        s = s.with_values({k: v for k, v in vals.items() if v is not None}, "load case")
    if cli:
        s = s.with_values({k: v for k, v in cli.items() if v is not None}, "command line")
    if s.width_min >= s.width_max:
        raise SettingsError(f"width_min = {s.width_min} must be below width_max = {s.width_max} (x nozzle)")
    return s


# ---------------------------------------------------------------------------------------------- front ends


def _default_note(f: Field) -> str:
    """The flag's default for its help: none where the help says what happens when it is not set
    (:attr:`Field.help_says_default`), a kind list as the flag takes it."""
    if f.help_says_default:
        return ""
    shown = ",".join(f.default) if isinstance(f.default, tuple) else repr(f.default)
    return f" (default {shown})"


def add_cli_options(parser: argparse.ArgumentParser) -> None:
    """Add the schema's own flags and ``--set KEY=VALUE`` to a parser (values default to None)."""
    for f in SCHEMA:
        if f.cli is None:
            continue
        metavar = {"float": "X", "optional_float": "MM", "int": "N", "kinds": "KINDS"}.get(f.kind)
        kw: dict[str, Any] = {
            "dest": f"set_{f.name}",
            "default": None,
            "help": f.help + (f" [{f.unit}]" if f.unit else "") + _default_note(f),
        }
        if f.choices and f.kind == "str":
            kw["choices"] = f.choices
        else:
            kw["metavar"] = metavar or "VALUE"
        parser.add_argument(f.cli, **kw)
    parser.add_argument(
        "--set",
        dest="set_extra",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="any other setting, e.g. --set width_max=1.4 (see loadpath.plugin.settings.SCHEMA)",
    )
    parser.add_argument(
        "--no-cache",
        dest="no_cache",
        action="store_true",
        help="neither reuse nor keep stress analyses and paths of earlier runs (same as --set cache=false)",
    )
    parser.add_argument(
        "--slicer-settings",
        metavar="FILE.json",
        default=None,
        help="the slicer's resolved settings as JSON with the slicer's own keys (the Cura plugin "
        "writes it: retraction_amount, speed_travel, material_diameter, ...)",
    )


def cli_values(args: argparse.Namespace) -> dict[str, Any]:
    """Field values given on the command line (parsed by :func:`add_cli_options`)."""
    out = {
        f.name: getattr(args, f"set_{f.name}")
        for f in SCHEMA
        if f.cli is not None and getattr(args, f"set_{f.name}", None) is not None
    }
    for item in getattr(args, "set_extra", []) or []:
        if "=" not in item:
            raise SettingsError(f"--set {item!r} must look like KEY=VALUE (e.g. --set width_max=1.4)")
        key, value = (x.strip() for x in item.split("=", 1))
        out[key] = value  # an unknown key fails in the job (Settings.with_values), where --on-failure
        # keep applies and the message says what became of the files
    if getattr(args, "no_cache", False):
        out["cache"] = False
    return out


def cura_setting_definitions(groups: Sequence[str] = ("toolpath",)) -> dict[str, dict[str, Any]]:
    """Describe the schema as Cura ``getSettingDataString`` settings (type, default value, unit, ...)."""
    types = {
        "str": "enum",
        "float": "float",
        "optional_float": "float",
        "int": "int",
        "bool": "bool",
        "kinds": "str",
    }
    out: dict[str, dict[str, Any]] = {}
    for f in SCHEMA:
        if f.group not in groups:
            continue
        d: dict[str, Any] = {
            "label": f.name.replace("_", " ").capitalize(),
            "description": f.help,
            "type": types[f.kind] if f.choices or f.kind != "str" else "str",
            "default_value": (
                ",".join(f.default) if f.kind == "kinds" else 0.0 if f.default is None else f.default
            ),
        }
        if f.unit:
            d["unit"] = f.unit
        if f.minimum is not None and f.kind != "optional_float":
            d["minimum_value"] = str(f.minimum)
        if f.maximum is not None:
            d["maximum_value"] = str(f.maximum)
        if f.choices and f.kind == "str":
            d["options"] = {c: c for c in f.choices}
        out[f.name] = d
    return out


def splice_options(s: Settings):
    """Build the splicer's options (:class:`loadpath.splice.SpliceOptions`) for these settings."""
    from loadpath.splice import Motion, PlanOptions, Retraction, SpliceOptions
    from loadpath.splice.flow import FlowModel

    flow = FlowModel(s.flow_model, s.filament_diameter, s.extrusion_multiplier, s.volumetric_e)
    retraction = Retraction(
        length=s.retract_length,
        speed=s.retract_speed,
        deretract_speed=s.deretract_speed,
        restart_extra=s.retract_restart_extra,
        lift=s.retract_lift,
        lift_speed=s.travel_speed_z,
        before_travel=s.retract_before_travel,
        only_when_crossing=s.only_retract_when_crossing_perimeters,
        wipe=s.wipe,
        before_wipe=s.retract_before_wipe,
        firmware=s.use_firmware_retraction,
        avoid_crossing=s.avoid_crossing_perimeters,
    )
    plan = PlanOptions(
        nozzle_diameter=s.nozzle_diameter,
        width_range=(s.width_min, s.width_max),
        link_max=s.link_max,
        max_volumetric_speed=s.max_volumetric_speed,
        match_volume=s.match_volume,
        max_correction=s.max_correction,
    )
    return SpliceOptions(flow=flow, motion=Motion(s.travel_speed, retraction), plan=plan)
