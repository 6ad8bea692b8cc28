"""Run the plugin's Modify G-Code script the way Cura 4.13 does, headless, on Cura's own Python.

Usage: ``/usr/bin/python3 cura_driver.py JOB.json`` (Debian's Cura runs on the system Python, with
its shapely 1.8 and no loadpath: the script must work there).  JOB.json holds ``chunks`` (the chunk
list), ``values`` (the script's settings that differ from their defaults), ``stacks`` (Cura's
resolved settings, ``{"global": {...}, "extruders": [...]}``) and ``out`` (where to write the
result).  The script is found and loaded by Cura's real ``PostProcessingPlugin.loadScripts`` from the
plugin's ``scripts/`` folder, and subclassed only to answer ``getSettingValueByKey`` from a dict
(real-tools.md §5.2; the real ``initialize()`` needs a running Cura) and to give it the stacks.
"""

import json
import sys
import types

sys.path.insert(0, "/usr/lib/cura/plugins")  # real-tools.md §5.1

from PostProcessingPlugin.PostProcessingPlugin import PostProcessingPlugin  # noqa: E402
from PostProcessingPlugin.Script import Script  # noqa: E402


class Stack:
    """A container stack's ``getProperty(key, "value")`` over resolved values (CuraEngine's listing)."""

    def __init__(self, values, extruders=()):
        self.values = values
        self.extruderList = list(extruders)

    def getProperty(self, key, prop):
        assert prop == "value"
        v = self.values.get(key)
        if v in ("true", "false"):
            return v == "true"
        try:
            return int(v) if str(v).lstrip("-").isdigit() else float(v)
        except (TypeError, ValueError):
            return v


def main(job_path):
    with open(job_path, encoding="utf-8") as fh:
        job = json.load(fh)
    # Cura's own loader (PostProcessingPlugin.loadScripts) on the plugin's scripts folder
    loader = types.SimpleNamespace(
        _loaded_scripts={}, _script_labels={}, _isScriptAllowed=PostProcessingPlugin._isScriptAllowed
    )
    PostProcessingPlugin.loadScripts(loader, job["scripts_dir"])
    loaded = loader._loaded_scripts["LoadpathScript"]
    assert issubclass(loaded, Script) and loaded is not Script

    # Uranium's own DefinitionContainer reads the settings (as Script.initialize() does); the real
    # VersionUpgradeManager, with no upgrade plug-ins, is all it needs besides a running Cura.
    from UM.Settings.DefinitionContainer import DefinitionContainer
    from UM.VersionUpgradeManager import VersionUpgradeManager

    if VersionUpgradeManager.getInstance() is None:
        VersionUpgradeManager(None)
    definition = DefinitionContainer("LoadpathScript")
    definition.deserialize(json.dumps(loaded().getSettingData()))
    definitions = {
        d.key: {"type": d.type, "default_value": d.default_value} for d in definition.findDefinitions()
    }
    defaults = {k: v["default_value"] for k, v in definitions.items()}
    values = {**defaults, **job["values"]}
    stacks = job.get("stacks")

    class Headless(loaded):
        def getSettingValueByKey(self, key):
            return values[key]

        def cura_stacks(self):
            if not stacks:
                return None, None
            ex = [Stack(e) for e in stacks["extruders"]]
            return Stack(stacks["global"], ex), ex

        def report_root(self):
            return job["report_root"]

    script = Headless()
    data = script.execute(list(job["chunks"]))
    runner = sys.modules["_loadpath_cura_runner"]  # what the script loaded
    with open(job["out"], "w", encoding="utf-8") as fh:
        json.dump(
            {
                "chunks": data,
                "labels": loader._script_labels,
                "definitions": definitions,
                "cura_settings": runner.stack_settings(*script.cura_stacks()) if stacks else None,
            },
            fh,
        )


if __name__ == "__main__":
    main(sys.argv[1])
