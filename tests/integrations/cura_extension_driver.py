"""Load the plugin as Uranium does and drive its Extensions menu and save hook, on Cura's own Python.

Usage: ``/usr/bin/python3 cura_extension_driver.py JOB.json``.  The plugin package is imported by its
id (as ``PluginRegistry`` does), its ``plugin.json`` is read by Uranium's own ``_parsePluginInfo`` and
checked with ``isPluginApiVersionCompatible`` against this Cura's SDK version, and ``register(app)``
runs with an application object that hands out real Uranium parts: ``Preferences``, a ``Signal`` for
``writeStarted``, and a scene holding the chunk list.  Then the preferences the menu items would set
are set, ``writeStarted`` is emitted (a save), and "Show last report" is called.  ``earlier_report``
(file name -> text) is put in the last-report folder before the save, as an earlier run left it.
"""

import json
import os
import sys
import types

sys.path.insert(0, "/usr/lib/cura/plugins")  # real-tools.md §5.1

from cura.ApplicationMetadata import CuraSDKVersion  # noqa: E402
from UM.PluginRegistry import PluginRegistry  # noqa: E402
from UM.Preferences import Preferences  # noqa: E402
from UM.Resources import Resources  # noqa: E402
from UM.Signal import Signal  # noqa: E402
from UM.Version import Version  # noqa: E402


def main(job_path):
    with open(job_path, encoding="utf-8") as fh:
        job = json.load(fh)
    plugin_dir = job["plugin_dir"]
    sys.path.insert(0, os.path.dirname(plugin_dir))
    import LoadpathInfill as plugin  # Uranium imports a plugin under its id

    meta = plugin.getMetaData()
    with open(os.path.join(plugin_dir, "plugin.json"), encoding="utf-8") as fh:
        PluginRegistry._parsePluginInfo(None, "LoadpathInfill", fh.read(), meta)
    registry = types.SimpleNamespace(_api_version=Version(CuraSDKVersion))
    compatible = any(
        PluginRegistry.isPluginApiVersionCompatible(registry, v)
        for v in meta["plugin"]["supported_sdk_versions"]
    )

    prefs = Preferences()
    write_started = Signal(type=Signal.Direct)
    scene = types.SimpleNamespace(gcode_dict={0: list(job["chunks"])} if job["chunks"] else {},
                                  getRoot=lambda: _plate(job.get("mesh")))
    app = types.SimpleNamespace(
        getPreferences=lambda: prefs,
        getOutputDeviceManager=lambda: types.SimpleNamespace(writeStarted=write_started),
        getController=lambda: types.SimpleNamespace(getScene=lambda: scene),
        getMultiBuildPlateModel=lambda: types.SimpleNamespace(activeBuildPlate=0),
        getGlobalContainerStack=lambda: None,
    )
    ext = plugin.register(app)["extension"]
    search = [os.path.normpath(p) for p in Resources.getAllPathsForType(Resources.Resources)]

    for key, value in job["preferences"].items():  # what the menu's dialogs store
        prefs.setValue("loadpath/" + key, value)
    if job.get("edit"):  # Extensions > Loadpath infill > Edit load case...
        ext.editLoadCase()
        with open(job["out"], "w", encoding="utf-8") as fh:
            json.dump({"message": ext.lastMessage, "pid": ext._editor.pid if ext._editor else None,
                       "loadcase": prefs.getValue("loadpath/loadcase"), "items": ext.getMenuItemList()}, fh)
        return
    earlier = os.path.join(ext.reportRoot(), "last-report")
    for name, text in (job.get("earlier_report") or {}).items():  # an earlier run's report
        os.makedirs(earlier, exist_ok=True)
        with open(os.path.join(earlier, name), "w", encoding="utf-8") as fh:
            fh.write(text)
    write_started.emit(None)  # a save
    first = list(scene.gcode_dict[0])
    saved_message = ext.lastMessage
    write_started.emit(None)  # a second save of the same chunks: not processed again
    ext.showLastReport()
    with open(job["out"], "w", encoding="utf-8") as fh:
        json.dump(
            {
                "compatible": compatible,
                "sdk": CuraSDKVersion,
                "menu": ext.getMenuName(),
                "items": ext.getMenuItemList(),
                "plugin_dir_searched": os.path.normpath(plugin_dir) in search,
                "chunks": first,
                "again": scene.gcode_dict[0],
                "saved_message": saved_message,
                "report_message": ext.lastMessage,
                "report_dir": earlier,
                "qt": sys.modules[type(ext).__module__].QUrl.__module__,
            },
            fh,
        )


def _plate(mesh):
    """A scene root holding one sliceable node with the given mesh (Cura's axes, y up)."""
    import numpy
    from cura.Scene.SliceableObjectDecorator import SliceableObjectDecorator
    from UM.Mesh.MeshBuilder import MeshBuilder
    from UM.Scene.SceneNode import SceneNode

    root = SceneNode()
    if mesh:
        node = SceneNode(parent=root)
        mb = MeshBuilder()
        mb.setVertices(numpy.asarray(mesh["vertices"], dtype=numpy.float32))
        mb.setIndices(numpy.asarray(mesh["faces"], dtype=numpy.int32))
        node.setMeshData(mb.build())
        node.addDecorator(SliceableObjectDecorator())
    return root


if __name__ == "__main__":
    main(sys.argv[1])
