"""What the slicer says: machine values from its configuration, environment, settings or moves.

Sources: PrusaSlicer's configuration, its ``SLIC3R_*`` environment, Cura's settings JSON, or (for
files without settings) the file's own moves.

Each reader returns a dict of :class:`loadpath.plugin.settings.Settings` field names to raw values;
:func:`loadpath.plugin.settings.resolve` validates them and applies the precedence.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from loadpath.errors import SettingsError

__all__ = [
    "from_prusa_config",
    "from_slic3r_env",
    "read_cura_settings",
    "from_cura_settings",
    "infer_from_moves",
]


def _bool(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    s = str(value).strip().lower()
    if s in ("1", "true", "yes", "on"):
        return True
    if s in ("0", "false", "no", "off", ""):
        return False
    raise SettingsError(f"{value!r} is not a yes/no value (use true or false)")


_PRUSA_KEYS = {  # Settings field -> PrusaSlicer option, then OrcaSlicer's / Bambu Studio's name for it
    "nozzle_diameter": ("nozzle_diameter",),
    "filament_diameter": ("filament_diameter",),
    "volumetric_e": ("use_volumetric_e",),
    "travel_speed": ("travel_speed",),
    "travel_speed_z": ("travel_speed_z",),
    "retract_length": ("retract_length", "retraction_length"),
    "retract_speed": ("retract_speed", "retraction_speed"),
    "deretract_speed": ("deretract_speed", "deretraction_speed"),  # both: 0 = the retraction speed
    "retract_restart_extra": ("retract_restart_extra",),
    "retract_lift": ("retract_lift", "z_hop"),  # Orca: every z_hop_types value lifts by z_hop
    "retract_before_travel": ("retract_before_travel", "retraction_minimum_travel"),
    # Orca / Bambu "reduce_infill_retraction": no retraction for a travel inside the infill area; the
    # same test (RetractWhenCrossingPerimeters, inherited from PrusaSlicer) as PrusaSlicer's option
    "only_retract_when_crossing_perimeters": (
        "only_retract_when_crossing_perimeters",
        "reduce_infill_retraction",
    ),
    "avoid_crossing_perimeters": ("avoid_crossing_perimeters", "reduce_crossing_wall"),
    "wipe": ("wipe",),
    "retract_before_wipe": ("retract_before_wipe",),
    "use_firmware_retraction": ("use_firmware_retraction",),
}
"""Settings field -> configuration keys, first present wins (per-extruder options: the tool's value).

OrcaSlicer and Bambu Studio (``; CONFIG_BLOCK_START``) renamed some of PrusaSlicer's options and kept
the others; the flow multiplier is :func:`_orca_flow` there."""


def _first(value: str) -> str:
    return str(value).split(",")[0].strip()


def from_prusa_config(config: Mapping[str, str], tool: int = 0) -> dict[str, Any]:
    """Machine values from a PrusaSlicer-family configuration (keys case-insensitive).

    PrusaSlicer's and SuperSlicer's option names, and OrcaSlicer's / Bambu Studio's where they renamed
    one (:data:`_PRUSA_KEYS`).  Per-extruder options (``"0.4,0.4"``) take the value of ``tool``.  The
    volumetric limit is the smaller non-zero of ``max_volumetric_speed`` and
    ``filament_max_volumetric_speed``.  The extrusion multiplier is PrusaSlicer's
    ``extrusion_multiplier``, else OrcaSlicer's ``filament_flow_ratio`` times ``print_flow_ratio``.
    """
    cfg = {k.lower(): v for k, v in config.items()}
    out: dict[str, Any] = {}

    def pick(key: str) -> str | None:
        if key not in cfg:
            return None
        parts = [p.strip() for p in str(cfg[key]).split(",")]
        return parts[tool] if tool < len(parts) else parts[0]

    for name, keys in _PRUSA_KEYS.items():
        for key in keys:
            v = pick(key)
            if v is not None and v != "":
                out[name] = v
                break
    flow = pick("extrusion_multiplier")
    if flow not in (None, ""):
        out["extrusion_multiplier"] = flow
    else:
        ratios = [pick("filament_flow_ratio"), pick("print_flow_ratio")]
        if any(r not in (None, "") for r in ratios):
            out["extrusion_multiplier"] = _orca_flow(*ratios)
    if "retract_before_wipe" in out:
        rbw = str(out["retract_before_wipe"])
        out["retract_before_wipe"] = float(rbw.rstrip("%")) / 100.0 if rbw.endswith("%") else float(rbw)
    limits = [
        float(x)
        for x in (pick("max_volumetric_speed"), pick("filament_max_volumetric_speed"))
        if x not in (None, "") and float(x) > 0
    ]
    if limits:
        out["max_volumetric_speed"] = min(limits)
    elif "max_volumetric_speed" in cfg or "filament_max_volumetric_speed" in cfg:
        out["max_volumetric_speed"] = 0.0
    if cfg:
        out["flow_model"] = "rounded"
    return out


def _orca_flow(filament: str | None, process: str | None) -> float:
    """Return OrcaSlicer's / Bambu Studio's flow multiplier.

    The filament's ``filament_flow_ratio`` times the process's ``print_flow_ratio`` (each 1 when
    absent): Orca scales every extrusion by both.  Its role ratios (``sparse_infill_flow_ratio``, ...,
    used only with ``set_other_flow_ratios``) are not read.
    """
    try:
        return float(filament or 1.0) * float(process or 1.0)
    except ValueError as exc:
        raise SettingsError(
            f"flow ratio {filament!r} x {process!r} (filament_flow_ratio, print_flow_ratio) is not a number; "
            "fix the slicer configuration"
        ) from exc


def from_slic3r_env(env: Mapping[str, str] | None = None) -> dict[str, str]:
    r"""PrusaSlicer's options from ``SLIC3R_*`` environment variables, as a config dict (lower-case keys).

    PrusaSlicer upper-cases the whole name (``SLIC3R_FILL_DENSITY``); the help article shows mixed
    case (``SLIC3R_Fill_density``): both are read.  Multi-line values keep their literal ``\\n``.
    """
    env = os.environ if env is None else env
    skip = {"slic3r_pp_host", "slic3r_pp_output_name"}
    return {
        k[7:].lower(): v for k, v in env.items() if k.lower().startswith("slic3r_") and k.lower() not in skip
    }


_CURA_KEYS = {  # Settings field -> Cura setting keys, first present wins (extruder values over global)
    "nozzle_diameter": ("machine_nozzle_size",),
    "filament_diameter": ("material_diameter",),
    "travel_speed": ("speed_travel",),
    "retract_length": ("retraction_amount",),
    "retract_speed": ("retraction_retract_speed", "retraction_speed"),
    "deretract_speed": ("retraction_prime_speed", "retraction_speed"),
    "retract_before_travel": ("retraction_min_travel",),
    "travel_speed_z": ("speed_z_hop",),
}


def read_cura_settings(path: str | os.PathLike) -> dict[str, Any]:
    """Read the JSON the Cura plugin writes: ``{"global": {...}, "extruders": [{...}, ...]}`` or flat.

    Extruder 0's values win over the global ones.  Keys are Cura's own setting keys.
    """
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise SettingsError(
            f"cannot read Cura settings {str(p)!r}: {exc.strerror or exc}; check the path"
        ) from exc
    except ValueError as exc:
        raise SettingsError(
            f"Cura settings {str(p)!r} is not valid JSON ({exc}); pass the file the Cura plugin wrote"
        ) from exc
    if not isinstance(data, dict):
        raise SettingsError(f"Cura settings {str(p)!r} must hold a JSON object of setting keys")
    flat = dict(data.get("global", {})) if "global" in data or "extruders" in data else dict(data)
    extruders = data.get("extruders") or []
    if extruders and isinstance(extruders[0], dict):
        flat.update(extruders[0])
    return flat


def from_cura_settings(cura: Mapping[str, Any]) -> dict[str, Any]:
    """Machine values from Cura's resolved settings (its own keys, e.g. ``retraction_amount``)."""
    out: dict[str, Any] = {"flow_model": "rectangle"}
    for name, keys in _CURA_KEYS.items():
        for k in keys:
            if k in cura and cura[k] not in (None, ""):
                out[name] = cura[k]
                break
    flow = cura.get("infill_material_flow", cura.get("material_flow"))
    if flow not in (None, ""):
        out["extrusion_multiplier"] = float(flow) / 100.0
    if "retraction_enable" in cura and not _bool(cura["retraction_enable"]):
        out["retract_length"] = 0.0
    if _bool(cura.get("retraction_hop_enabled", False)):
        out["retract_lift"] = cura.get("retraction_hop", 0.0)
    elif "retraction_hop_enabled" in cura:
        out["retract_lift"] = 0.0
    combing = str(cura.get("retraction_combing", "")).strip().lower()
    if combing:
        out["only_retract_when_crossing_perimeters"] = combing != "off"
        out["avoid_crossing_perimeters"] = combing != "off"
    if "relative_extrusion" in cura:
        pass  # the E mode is read from the file itself
    out["wipe"] = False
    out["use_firmware_retraction"] = _bool(cura.get("machine_firmware_retract", False))
    return out


def infer_from_moves(program) -> dict[str, Any]:
    """Machine values read from the file's own moves (for files without settings: Cura's).

    Travel speed: the most common feedrate of XY travels; retraction: the most common E-only pull
    and its feedrate, the most common push feedrate; z-hop: the most common lift that follows a
    retraction; retract-before-travel: 0 when short travels retract too.  Fields that cannot be
    read are left out.
    """
    m = program.moves
    out: dict[str, Any] = {}

    def mode(v: np.ndarray) -> float | None:
        v = v[np.isfinite(v)]
        if len(v) == 0:
            return None
        vals, counts = np.unique(np.round(v, 4), return_counts=True)
        return float(vals[np.argmax(counts)])

    t = m[m["travel"] & (m["layer"] >= 0)]
    f = mode(t["f"])
    if f:
        out["travel_speed"] = f / 60.0
    r = m[m["retract"] & (m["e"] < 0)]
    if len(r):
        # filament held back once the retraction (wipe included) is complete
        out["retract_length"] = mode(program.state.retracted[r["line"]])
        fr = mode(r["f"])
        if fr:
            out["retract_speed"] = fr / 60.0
    u = m[m["unretract"] & (m["e"] > 0)]
    fu = mode(u["f"]) if len(u) else None
    if fu:
        out["deretract_speed"] = fu / 60.0
    after_retract = np.zeros(len(m), dtype=bool)
    after_retract[1:] = m["retract"][:-1]
    lifts = m[m["lift"] & ~m["travel"] & after_retract]  # z-hops follow a retraction; layer changes need not
    dz = mode(lifts["z1"] - lifts["z0"]) if len(lifts) else None
    out["retract_lift"] = dz if dz and dz < 5.0 else 0.0
    if len(lifts):
        fz = mode(lifts["f"])
        if fz:
            out["travel_speed_z"] = fz / 60.0
    out["wipe"] = bool(np.any(m["wipe"] & (m["e"] < 0)))
    combing = _combs(program)
    if combing is None and getattr(program.dialect, "family", "") == "cura":
        combing = True  # CuraEngine's default, retraction_combing = "all" (fdmprinter.def.json)
    if combing is not None:
        out["only_retract_when_crossing_perimeters"] = combing
        out["avoid_crossing_perimeters"] = combing
    return {k: v for k, v in out.items() if v is not None}


def _combs(program, long: float = 2.0, least: int = 20) -> bool | None:
    """Whether the file combs: most of its travels of ``long`` mm or more between two extrusions of
    one layer are made without a retraction (Cura's combing; CuraEngine 4.13 retracts 0-11 times in
    a file with thousands of travels).  A travel is everything between two extrusions (a combed
    travel is several moves).  None when the file has fewer than ``least`` such travels.
    """
    m = program.moves
    ext = np.flatnonzero(m["extrude"])
    if len(ext) < 2:
        return None
    xy = np.where(m["travel"], np.hypot(m["x1"] - m["x0"], m["y1"] - m["y0"]), 0.0)
    c_len = np.concatenate([[0.0], np.cumsum(xy)])
    c_ret = np.concatenate([[0], np.cumsum(m["retract"] | (m["wipe"] & (m["e"] < 0)))])
    i, j = ext[:-1], ext[1:]
    length = c_len[j] - c_len[i + 1]
    pulled = (c_ret[j] - c_ret[i + 1]) > 0
    same = (m["layer"][i] == m["layer"][j]) & (m["layer"][i] >= 0)
    t = same & (length >= long)
    if int(t.sum()) < least:
        return None
    return bool(np.mean(pulled[t]) < 0.5)
