"""The declared package list matches the folders, and the console scripts are declared."""

from __future__ import annotations

import configparser

from conftest import REPO
from setuptools import find_packages


def _declared() -> tuple[list[str], dict[str, str]]:
    cfg = configparser.ConfigParser()
    cfg.read(REPO / "setup.cfg")
    packages = [p.strip() for p in cfg["options"]["packages"].split("\n") if p.strip()]
    mapping = {}
    for line in cfg["options"]["package_dir"].split("\n"):
        if line.strip():
            k, v = (s.strip() for s in line.split("=", 1))
            mapping[k] = v
    return packages, mapping


def test_declared_packages_match_folders():
    packages, mapping = _declared()
    found = set()
    for name, folder in mapping.items():
        found.add(name)
        found.update(f"{name}.{sub}" for sub in find_packages(str(REPO / folder)))
    assert sorted(found) == sorted(packages)


def test_package_dir_maps_the_repository_folders():
    _, mapping = _declared()
    assert mapping == {
        "loadpath": "core",
        "loadpath.plugin": "plugin",
        "loadpath.prusaslicer_postproc": "prusaslicer_postproc",
        "loadpath.examples": "examples",
    }
    # the Cura plugin folder is a Cura plugin, not a Python package of ours
    assert not (REPO / "cura_plugin" / "__init__.py").exists()


def test_console_scripts_declared():
    cfg = configparser.ConfigParser()
    cfg.read(REPO / "setup.cfg")
    scripts = cfg["options.entry_points"]["console_scripts"]
    assert "loadpath = loadpath.plugin.cli:main" in scripts
    assert "loadpath-prusaslicer = loadpath.prusaslicer_postproc:main" in scripts
