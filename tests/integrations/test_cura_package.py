"""The Cura plugin folder, its ``.curapackage`` and the runner's pieces that need no Cura."""

from __future__ import annotations

import ast
import json
import os
import py_compile
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import loadpath
import pytest
from fixtures import load_script
from integration_helpers import RUNNER, VENV_BIN, write_case

REPO = Path(__file__).resolve().parents[2]
PLUGIN = REPO / "cura_plugin" / "LoadpathInfill"
sys.path.insert(0, str(REPO / "scripts"))
import build_curapackage  # noqa: E402


def _runner():
    return load_script(RUNNER, "loadpath_runner_under_test")


runner = _runner()


def _sdk_compatible(declared: str, app: str) -> bool:
    """Uranium's rule (PluginRegistry.isPluginApiVersionCompatible): same major, minor not above."""
    d, a = (tuple(int(x) for x in v.split(".")[:2]) for v in (declared, app))
    return d[0] == a[0] and d[1] <= a[1]


def test_plugin_json_declares_cura_4_13_and_5():
    meta = json.loads((PLUGIN / "plugin.json").read_text(encoding="utf-8"))
    assert {"name", "author", "version", "description"} <= set(meta)
    assert meta["version"] == loadpath.__version__
    for app in ("7.9.0", "8.0.0", "8.9.0"):  # Cura 4.13 (Debian 12), Cura 5.0, Cura 5.10
        assert any(_sdk_compatible(v, app) for v in meta["supported_sdk_versions"]), app
    assert not any(_sdk_compatible(v, "6.0.0") for v in meta["supported_sdk_versions"])


def test_settings_schema_file_is_generated_from_loadpaths_schema():
    assert (PLUGIN / "settings_schema.json").read_text(encoding="utf-8") == build_curapackage.schema_text(), (
        "cura_plugin/LoadpathInfill/settings_schema.json is stale: run scripts/build_curapackage.py"
    )
    assert build_curapackage.main(["--check"]) == 0


def test_curapackage_structure(tmp_path):
    pkgs = [build_curapackage.build(tmp_path, sdk) for sdk in build_curapackage.SDKS]
    for pkg, sdk in zip(pkgs, build_curapackage.SDKS, strict=True):
        with zipfile.ZipFile(pkg) as zf:
            names = set(zf.namelist())
            meta = json.loads(zf.read("package.json"))
            assert meta["package_id"] == "LoadpathInfill" and meta["package_type"] == "plugin"
            assert meta["sdk_version_semver"] == sdk and meta["sdk_version"] == int(sdk.split(".")[0])
            assert meta["package_version"] == loadpath.__version__
            assert {"display_name", "description", "author", "website"} <= set(meta)
            root = "files/plugins/LoadpathInfill/"
            assert {
                root + f
                for f in (
                    "plugin.json",
                    "__init__.py",
                    "LoadpathInfill.py",
                    "loadpath_runner.py",
                    "settings_schema.json",
                    "scripts/LoadpathScript.py",
                )
            } <= names
            assert all(n == "package.json" or n == "LICENSE" or n.startswith(root) for n in names)
            assert not any("__pycache__" in n or n.endswith(".pyc") for n in names)
            # the packaged files are the folder's, and they compile
            zf.extractall(tmp_path / sdk)
        for f in build_curapackage.plugin_files():
            packed = tmp_path / sdk / root / f.relative_to(PLUGIN)
            assert packed.read_bytes() == f.read_bytes()
            if f.suffix == ".py":
                py_compile.compile(str(packed), doraise=True)


def test_plugin_uses_only_the_standard_library():
    """Cura's Python has no osqp/gmsh and an old shapely: the plugin imports Cura, Qt and stdlib only."""
    allowed = set(sys.stdlib_module_names) | {"UM", "cura", "PyQt5", "PyQt6"}
    for f in PLUGIN.rglob("*.py"):
        tree = ast.parse(f.read_text(encoding="utf-8"), str(f))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                mods = [node.module]
            else:
                continue
            for m in mods:
                assert m.split(".")[0] in allowed, (f.name, m)


@pytest.mark.parametrize(
    "chunks",
    [
        [";FLAVOR:Marlin\n;TIME:1\n", ";Generated\nG28\n", ";LAYER:0\nG1 X1\n", ";LAYER:1\nG1 X2\n", "M84\n"],
        ["no newline", "", ";LAYER:0\n", "\n", "end without newline"],
        ["only one chunk\n"],
    ],
)
def test_join_split_round_trip(chunks):
    text, flags = runner.join_chunks(chunks)
    assert text.count(runner.SEPARATOR) == len(chunks) - 1
    assert runner.split_chunks(text, flags) == chunks


def test_split_refuses_lost_separators():
    text, flags = runner.join_chunks(["a\n", "b\n", "c\n"])
    with pytest.raises(runner.RunnerError, match="separator"):
        runner.split_chunks(text.replace(runner.SEPARATOR + "\n", "", 1), flags)


def test_options_pass_only_what_differs_from_loadpaths_defaults():
    values = {
        "engine": "swarm",
        "pitch": 0.0,
        "K": "7.5",
        "principal": "max_abs",
        "replace": "solid,sparse",
        "stagger": False,
        "match_volume": True,
    }
    assert runner.options_from(values.get) == {"K": 7.5, "replace": "solid,sparse", "stagger": False}
    assert runner.options_from({"pitch": 0.45}.get) == {"pitch": 0.45}


def test_stack_settings_reads_global_and_extruders():
    class Stack:
        def __init__(self, values, extruders=()):
            self.values, self.extruderList = values, list(extruders)

        def getProperty(self, key, prop):
            return self.values.get(key)

    ex = Stack({"material_diameter": 2.85, "retraction_amount": 6.5})
    got = runner.stack_settings(Stack({"layer_height": 0.2, "speed_travel": 150}, [ex]))
    assert got == {
        "global": {"layer_height": 0.2, "speed_travel": 150},
        "extruders": [{"material_diameter": 2.85, "retraction_amount": 6.5}],
    }
    assert runner.stack_settings(None) is None


def test_missing_command_and_load_case_are_one_line_messages(tmp_path):
    out = runner.process_chunks(
        [";LAYER:0\n"], str(tmp_path / "none.toml"), command=str(VENV_BIN / "loadpath")
    )
    assert not out.ok and "does not exist" in out.message and out.chunks == [";LAYER:0\n"]
    with pytest.raises(runner.RunnerError, match="full path"):
        runner.find_command(str(tmp_path / "missing-loadpath"))


def test_timeout_kills_the_whole_run(tmp_path, prusa_ohs, monkeypatch):
    """The real command on a real file, with a timeout it cannot meet: killed, with its workers.

    The runner's work folder goes under this test's own folder, so the process check below sees only
    this run's processes (other runs of the plugin on the machine have their own folders).
    """
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    chunks = [prusa_ohs.read_text(encoding="utf-8")]
    t = time.monotonic()
    out = runner.process_chunks(
        chunks, str(write_case(tmp_path)), {"jobs": 2}, command=str(VENV_BIN / "loadpath"), timeout=1.5
    )
    assert not out.ok and "did not finish within 1.5 s" in out.message
    assert time.monotonic() - t < 10
    assert out.chunks == chunks
    left = subprocess.run(
        ["pgrep", "-f", f"loadpath run .*{tmp_path}{os.sep}loadpath-cura-"], capture_output=True, text=True
    )
    assert left.stdout.strip() == "", "processes of the killed run are still alive"
