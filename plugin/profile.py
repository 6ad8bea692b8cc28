"""PrusaSlicer's bundled vendor presets, flattened into one ``.ini`` its command line can ``--load``.

PrusaSlicer 2.5's command line cannot select a vendor preset by name, and ``--load`` does not
follow a bundle's ``inherits = parent1; parent2`` chains; this resolves the chains (parents in
order, later ones win, the preset's own keys last) and drops the bundle's meta keys::

    from loadpath.plugin.profile import flatten, write_ini
    keys = flatten("PrusaResearch", printer="Original Prusa i3 MK3S & MK3S+",
                   print_="0.20mm QUALITY @MK3", filament="Prusament PLA")
    write_ini(keys, "mk3s.ini")     # prusa-slicer --export-gcode --load mk3s.ini part.stl
"""

from __future__ import annotations

import difflib
import os
import re
from pathlib import Path

from loadpath.errors import SettingsError

__all__ = ["BUNDLES", "bundle_path", "read_bundle", "presets", "resolve", "flatten", "write_ini"]

BUNDLES = Path(os.environ.get("LOADPATH_PRUSA_PROFILES", "/usr/share/PrusaSlicer/profiles"))
"""Where PrusaSlicer keeps its vendor bundles (Debian's package; override with LOADPATH_PRUSA_PROFILES)."""

_META = {
    "inherits",
    "renamed_from",
    "alias",
    "compatible_printers",
    "compatible_printers_condition",
    "compatible_prints",
    "compatible_prints_condition",
}
_SECTION = re.compile(r"\[(printer|print|filament|sla_print|sla_material|printer_model):(.+)\]")

Sections = dict[tuple[str, str], dict[str, str]]


def bundle_path(vendor: str, folder: Path | None = None) -> Path:
    """``<folder>/<vendor>.ini``, or a path given as is; raises SettingsError naming the vendors there."""
    p = Path(vendor)
    if p.suffix == ".ini" and p.is_file():
        return p
    folder = BUNDLES if folder is None else Path(folder)
    p = folder / f"{vendor}.ini"
    if p.is_file():
        return p
    known = sorted(q.stem for q in folder.glob("*.ini")) if folder.is_dir() else []
    hint = f"; bundles there: {', '.join(known)}" if known else f"; is PrusaSlicer installed ({folder} is missing)?"
    raise SettingsError(f"no PrusaSlicer vendor bundle {vendor!r} in {str(folder)!r}{hint}")


def read_bundle(path: Path) -> Sections:
    """Sections ``(kind, name) -> {key: value}`` of a bundle (``[vendor]`` and other headers skipped)."""
    sections: Sections = {}
    current: dict[str, str] | None = None
    for raw in Path(path).read_text(encoding="utf-8").splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("["):
            m = _SECTION.fullmatch(line)
            current = sections.setdefault((m.group(1), m.group(2).strip()), {}) if m else None
            continue
        if current is not None and "=" in line:
            key, value = line.split("=", 1)
            current[key.strip()] = value.strip()
    return sections


def presets(sections: Sections, kind: str) -> list[str]:
    """The presets of a kind a user can pick (not the abstract ``*parents*``), sorted."""
    return sorted(n for k, n in sections if k == kind and not n.startswith("*"))


def resolve(sections: Sections, kind: str, name: str, _seen: tuple[str, ...] = ()) -> dict[str, str]:
    """A preset with its ``inherits`` chain applied (meta keys kept)."""
    if name in _seen:
        raise SettingsError(f"the bundle's {kind} preset {name!r} inherits from itself ({' -> '.join(_seen)})")
    own = sections.get((kind, name))
    if own is None:
        close = difflib.get_close_matches(name, presets(sections, kind), n=3, cutoff=0.5)
        hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        raise SettingsError(
            f"no {kind} preset {name!r} in the bundle{hint} (loadpath profile --list {kind} lists them)"
        )
    merged: dict[str, str] = {}
    for parent in own.get("inherits", "").split(";"):
        parent = parent.strip().strip('"')
        if parent:
            merged.update(resolve(sections, kind, parent, (*_seen, name)))
    merged.update(own)
    return merged


def flatten(vendor: str, printer: str, print_: str, filament: str, folder: Path | None = None) -> dict[str, str]:
    """The three presets of a vendor bundle merged into one flat key set (printer, print, filament order)."""
    sections = read_bundle(bundle_path(vendor, folder))
    out: dict[str, str] = {}
    for kind, name in (("printer", printer), ("print", print_), ("filament", filament)):
        out.update({k: v for k, v in resolve(sections, kind, name).items() if k not in _META})
    return out


def write_ini(keys: dict[str, str], path: str | os.PathLike[str]) -> Path:
    """Write ``key = value`` lines, sorted (what ``prusa-slicer --load`` reads)."""
    path = Path(path)
    try:
        path.write_text("".join(f"{k} = {v}\n" for k, v in sorted(keys.items())), encoding="utf-8")
    except OSError as exc:
        raise SettingsError(f"cannot write {str(path)!r}: {exc.strerror or exc}; choose another path") from None
    return path
