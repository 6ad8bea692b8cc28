#!/usr/bin/env python3
"""Build an installable ``.curapackage`` of the Cura plugin (``cura_plugin/LoadpathInfill``).

A ``.curapackage`` is a zip with ``package.json`` at the top and the plugin under
``files/plugins/<PluginId>/`` (slicer-conventions.md §12); drag it onto Cura's window to install it.
One package declares one SDK version, so one package is built per Cura generation: SDK 8 (Cura 5.x,
PyQt6) and SDK 7 (Cura 4.x, PyQt5); the plugin folder itself supports both.

The plugin's settings list is generated from loadpath's settings schema
(``loadpath.plugin.settings.cura_setting_definitions``) into ``settings_schema.json``; the build
rewrites it, ``--check`` fails when the committed file is stale (the tests do the same).

Usage (from the repository root)::

    .venv/bin/python scripts/build_curapackage.py [--out dist] [--sdk 8.0.0 --sdk 7.9.0] [--check]
"""

from __future__ import annotations

import argparse
import json
import sys
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PLUGIN_ID = "LoadpathInfill"
PLUGIN_DIR = REPO / "cura_plugin" / PLUGIN_ID
SCHEMA_FILE = "settings_schema.json"
SDKS = ("8.0.0", "7.9.0")  # Cura 5.x, Cura 4.13 (Debian 12)
SKIP = {"__pycache__", ".pytest_cache"}


def schema_json() -> dict:
    """The plugin's loadpath settings, generated from loadpath's schema."""
    from loadpath.plugin.settings import cura_setting_definitions

    return {
        "generated_from": "loadpath.plugin.settings.SCHEMA (scripts/build_curapackage.py); do not edit",
        "settings": cura_setting_definitions(("toolpath",)),
    }


def schema_text() -> str:
    return json.dumps(schema_json(), indent=1, sort_keys=False) + "\n"


def write_schema(plugin_dir: Path = PLUGIN_DIR) -> Path:
    """(Re)write ``settings_schema.json`` in the plugin folder."""
    path = plugin_dir / SCHEMA_FILE
    path.write_text(schema_text(), encoding="utf-8")
    return path


def package_json(sdk: str, plugin: dict) -> dict:
    """``package.json`` for one SDK version (fields of Cura's package format)."""
    major = sdk.split(".")[0]
    return {
        "package_id": PLUGIN_ID,
        "package_type": "plugin",
        "display_name": plugin["name"],
        "description": plugin["description"],
        "package_version": plugin["version"],
        "sdk_version": int(major),
        "sdk_version_semver": sdk,
        "website": "https://github.com/loadpath/loadpath",
        "author": {
            "author_id": "loadpath",
            "display_name": plugin["author"],
            "website": "https://github.com/loadpath/loadpath",
        },
        "tags": ["infill", "post-processing", "FEA"],
    }


def plugin_files(plugin_dir: Path = PLUGIN_DIR) -> list[Path]:
    """The files of the plugin folder that go into the package (no caches)."""
    return sorted(
        p
        for p in plugin_dir.rglob("*")
        if p.is_file() and not SKIP.intersection(p.relative_to(plugin_dir).parts) and p.suffix != ".pyc"
    )


def build(out_dir: Path, sdk: str, plugin_dir: Path = PLUGIN_DIR) -> Path:
    """Write ``<out_dir>/LoadpathInfill-<version>-sdk<sdk>.curapackage``; returns its path."""
    plugin = json.loads((plugin_dir / "plugin.json").read_text(encoding="utf-8"))
    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / f"{PLUGIN_ID}-{plugin['version']}-sdk{sdk}.curapackage"
    tmp = out.with_suffix(".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("package.json", json.dumps(package_json(sdk, plugin), indent=2) + "\n")
        for f in plugin_files(plugin_dir):
            zf.write(f, f"files/plugins/{PLUGIN_ID}/{f.relative_to(plugin_dir).as_posix()}")
        if (REPO / "LICENSE").is_file():
            zf.write(REPO / "LICENSE", "LICENSE")
    tmp.replace(out)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=REPO / "dist", help="output folder (default: dist)")
    ap.add_argument(
        "--sdk", action="append", default=None, help=f"SDK version(s) (default: {', '.join(SDKS)})"
    )
    ap.add_argument("--check", action="store_true", help="only check that settings_schema.json is current")
    args = ap.parse_args(argv)
    current = (
        (PLUGIN_DIR / SCHEMA_FILE).read_text(encoding="utf-8") if (PLUGIN_DIR / SCHEMA_FILE).exists() else ""
    )
    if args.check:
        if current != schema_text():
            print(f"{PLUGIN_DIR / SCHEMA_FILE} is stale: run scripts/build_curapackage.py", file=sys.stderr)
            return 1
        return 0
    if current != schema_text():
        print(f"updated {write_schema()}")
    for sdk in args.sdk or SDKS:
        print(build(args.out, sdk))
    return 0


if __name__ == "__main__":
    sys.exit(main())
