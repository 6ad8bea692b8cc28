"""Shared fixtures and the rule for tests that need real programs.

A test that needs PrusaSlicer, CuraEngine, Cura's Python modules or CalculiX asks for it with
:func:`require_tool`.  In CI (``CI=true``) a missing tool is a failure, never a skip; elsewhere the
test skips with the apt command that installs the tool.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")

# executable (or marker path) -> Debian package that provides it
TOOLS = {
    "prusa-slicer": "prusa-slicer",
    "CuraEngine": "cura-engine",
    "ccx": "calculix-ccx",
    "cura": "cura",  # Cura's Python modules and machine definitions
    "chromium": "chromium",  # the load-case editor's browser tests
    "chromedriver": "chromium-driver",
}

CURA_PLUGINS = Path("/usr/lib/cura/plugins")
CURA_RESOURCES = Path("/usr/share/cura/resources")


def tool_available(name: str) -> bool:
    if name == "cura":
        return (CURA_PLUGINS / "PostProcessingPlugin" / "Script.py").exists() and CURA_RESOURCES.is_dir()
    return shutil.which(name) is not None


def require_tool(name: str) -> None:
    """Skip (outside CI) or fail (in CI) when a real program is missing."""
    if tool_available(name):
        return
    msg = f"{name} is not installed: apt-get install {TOOLS[name]} (or run ./dev setup as root)"
    if IN_CI:
        pytest.fail(f"CI=true but {msg}")
    pytest.skip(msg)


REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


from editor_fixtures import *  # noqa: E402,F401,F403  the load-case editor: loadpath edit + Chromium
from fixtures import *  # noqa: E402,F401,F403  shared real-slicer fixtures (tests/fixtures.py)


@pytest.fixture(autouse=True)
def _state_home(tmp_path_factory, monkeypatch):
    """Every run appends its verdict to ``$XDG_STATE_HOME/loadpath/runs.log``: never the user's own."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path_factory.getbasetemp() / "state"))


@pytest.fixture(autouse=True)
def _own_result_cache(tmp_path_factory, monkeypatch):
    """Each test runs loadpath on its own empty result cache (loadpath.cache), never the user's.

    A test then measures its own run, and the cache tests fill and read theirs on purpose.
    """
    monkeypatch.setenv("LOADPATH_CACHE_DIR", str(tmp_path_factory.mktemp("loadpath-cache")))
