"""Embedded slicer configuration: PrusaSlicer / Orca / Bambu config blocks and Cura's ``;SETTING_3``.

Values are kept verbatim (strings); callers convert what they need (``float(config["fill_density"]
.rstrip("%"))``).  Per-extruder values stay comma separated (``"0.4,0.4"``).
"""

from __future__ import annotations

import json
import re

__all__ = ["parse_config_lines", "parse_cura_settings"]


def parse_config_lines(lines: list[bytes]) -> dict[str, str]:
    """``; key = value`` lines of a PrusaSlicer / Orca config block -> dict (values verbatim)."""
    out: dict[str, str] = {}
    for raw in lines:
        text = raw.decode("utf-8", "replace").lstrip(";").strip()
        if " = " in text:
            key, value = text.split(" = ", 1)
            out[key.strip()] = value
        elif text.endswith(" ="):
            out[text[:-2].strip()] = ""
    return out


_CURA_ESCAPE = re.compile(r"\\\\|\\n|\\r")
_CURA_UNESCAPE = {"\\\\": "\\", "\\n": "\n", "\\r": "\r"}


def parse_cura_settings(blob: bytes) -> dict[str, str]:
    r"""Read the ``;SETTING_3`` block Cura's GUI appends: global values, then extruder 0's on top.

    The block is JSON ``{"global_quality": "<ini>", "extruder_quality": ["<ini>", ...]}`` with
    ``\``, newline and carriage return escaped once more (``GCodeWriter.escape_characters``), cut
    into 80-byte ``;SETTING_3`` lines; each ini has a ``[values]`` section
    (``Ultimaker/Cura: plugins/GCodeWriter/GCodeWriter.py``).
    """
    unescaped = _CURA_ESCAPE.sub(lambda m: _CURA_UNESCAPE[m.group(0)], blob.decode("utf-8", "replace"))
    try:
        doc = json.loads(unescaped)
    except ValueError:
        return {}
    out: dict[str, str] = {}
    inis = [doc.get("global_quality", "")] + list(doc.get("extruder_quality", [])[:1])
    for ini in inis:
        section = None
        for line in str(ini).splitlines():
            line = line.strip()
            if line.startswith("[") and line.endswith("]"):
                section = line[1:-1]
            elif section == "values" and "=" in line:
                key, value = line.split("=", 1)
                out[key.strip()] = value.strip()
    return out
