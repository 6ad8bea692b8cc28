# Copyright (c) loadpath contributors. MIT licence.
"""Extensions > Loadpath infill: choose or edit the load case, engine, spacing and K; process the
G-code when it is saved; show the last run's report.  *Edit load case...* opens ``loadpath edit``
in the browser on the plate's last G-code (or, before slicing, its meshes as STL).

A thin shell: the work is done by ``loadpath_runner`` (standard library, out of process). The
settings are kept in Cura's preferences (``loadpath/...``), which the Modify G-Code script
(``scripts/LoadpathScript.py``) also falls back on. Processing at save time hooks
``OutputDeviceManager.writeStarted`` as Cura's PostProcessingPlugin does; a chunk list that was
already processed (by the script or by this menu) is left alone.
"""

import json
import os

from UM.Application import Application
from UM.Extension import Extension
from UM.Logger import Logger
from UM.Message import Message

from . import loadpath_runner as runner

try:
    from cura.ApplicationMetadata import CuraSDKVersion
except ImportError:  # not inside Cura
    CuraSDKVersion = "8.0.0"


def _sdk_major():
    try:
        return int(str(CuraSDKVersion).split(".")[0])
    except ValueError:  # development builds ("dev")
        return 8


if _sdk_major() >= 8:  # Cura 5.x: Qt 6
    from PyQt6.QtCore import QUrl
    from PyQt6.QtGui import QDesktopServices
    from PyQt6.QtWidgets import QFileDialog, QInputDialog, QMessageBox

    _YES = QMessageBox.StandardButton.Yes
    _NO = QMessageBox.StandardButton.No
else:  # Cura 4.x: Qt 5
    from PyQt5.QtCore import QUrl
    from PyQt5.QtGui import QDesktopServices
    from PyQt5.QtWidgets import QFileDialog, QInputDialog, QMessageBox

    _YES = QMessageBox.Yes
    _NO = QMessageBox.No

PREFERENCES = {  # loadpath/<key>: default
    "loadcase": "",
    "command": "",
    "service_url": "",
    "on_save": False,
    "options": "{}",
    "timeout": 600,
}
TITLE = "Loadpath infill"


class LoadpathInfill(Extension):
    """The Extensions menu entry (``register`` returns one instance)."""

    def __init__(self, app=None):
        super().__init__()
        self._app = app
        self.setMenuName(TITLE)
        self.addMenuItem("Choose load case...", self.chooseLoadCase)
        self.addMenuItem("Edit load case...", self.editLoadCase)
        self.addMenuItem("Toolpath options (engine, spacing, K)...", self.editOptions)
        self.addMenuItem("Process G-code when saving...", self.chooseOnSave)
        self.addMenuItem("loadpath command...", self.chooseCommand)
        self.addMenuItem("Show last report", self.showLastReport)
        self._message = None
        self._editor = None
        self.lastMessage = ""
        if app is not None:
            prefs = app.getPreferences()
            for key, default in PREFERENCES.items():
                prefs.addPreference("loadpath/" + key, default)
            app.getOutputDeviceManager().writeStarted.connect(self._onWriteStarted)

    # -------------------------------------------------------------------------------- preferences
    def pref(self, key):
        return self._app.getPreferences().getValue("loadpath/" + key)

    def setPref(self, key, value):
        self._app.getPreferences().setValue("loadpath/" + key, value)

    def options(self):
        try:
            values = json.loads(self.pref("options") or "{}")
        except ValueError:
            values = {}
        return runner.options_from(lambda key: values.get(key))

    def reportRoot(self):
        from UM.Resources import Resources

        return os.path.join(Resources.getCacheStoragePath(), "loadpath")

    # -------------------------------------------------------------------------------- menu items
    def chooseLoadCase(self):
        start = os.path.dirname(self.pref("loadcase") or "") or os.path.expanduser("~")
        path, _ = QFileDialog.getOpenFileName(None, "Load case for loadpath", start, "Load case (*.toml)")
        if path:
            self.setPref("loadcase", path)
            self._show("Load case: " + path)

    def editLoadCase(self):
        """Open the load-case editor on the plate: its last G-code, else its meshes as an STL."""
        folder = os.path.join(self.reportRoot(), "edit")
        case = self.pref("loadcase") or os.path.join(folder, "loadcase.toml")
        try:
            chunks = self._plateChunks()
            part = runner.edit_part(folder, chunks, None if chunks else self._plateTriangles())
            if self._editor is not None and self._editor.poll() is None:
                self._editor.terminate()  # one editor at a time
            log = os.path.join(folder, "editor.log")
            self._editor = runner.start_editor(self.pref("command"), part, case, log)
        except (runner.RunnerError, OSError) as exc:
            self._show("Cannot open the load-case editor: " + str(exc))
            return
        self.setPref("loadcase", case)
        what = "the last G-code" if part.endswith(".gcode") else "the plate's meshes (STL, frame = part)"
        self._show(f"The load-case editor opens in your browser on {what}; Save writes {case}, "
                   "the load case used when the G-code is processed.")

    def _plateChunks(self):
        scene = self._app.getController().getScene()
        gcode_dict = getattr(scene, "gcode_dict", None) or {}
        data = gcode_dict.get(self._app.getMultiBuildPlateModel().activeBuildPlate)
        return list(data) if data else None

    def _plateTriangles(self):
        """The printable meshes on the plate in slicer axes (Cura's y is up: (x, y, z) -> (x, -z, y))."""
        from UM.Scene.Iterator.DepthFirstIterator import DepthFirstIterator

        tris = []
        scene = self._app.getController().getScene()
        for node in DepthFirstIterator(scene.getRoot()):
            if not node.callDecoration("isSliceable") or node.getMeshData() is None:
                continue
            mesh = node.getMeshData()
            v = node.getMeshDataTransformedVertices()  # same order as the mesh's own vertices
            idx = mesh.getIndices() if mesh.hasIndices() else [(i, i + 1, i + 2) for i in range(0, len(v), 3)]
            for f in idx:
                tris.append([(float(v[k][0]), -float(v[k][2]), float(v[k][1])) for k in f])
        return tris

    def editOptions(self):
        spec = runner.schema()
        try:
            values = json.loads(self.pref("options") or "{}")
        except ValueError:
            values = {}
        engines = list(spec["engine"]["options"])
        current = values.get("engine", spec["engine"]["default_value"])
        engine, ok = QInputDialog.getItem(
            None, TITLE, "Engine", engines, engines.index(current) if current in engines else 0, False
        )
        if not ok:
            return
        pitch, ok = QInputDialog.getDouble(
            None,
            TITLE,
            "Spacing of the new paths, mm (0: the slicer's)",
            float(values.get("pitch", 0.0)),
            0.0,
            float(spec["pitch"]["maximum_value"]),
            3,
        )
        if not ok:
            return
        k, ok = QInputDialog.getDouble(
            None,
            TITLE,
            "K (swarm: stress alignment against even spacing)",
            float(values.get("K", spec["K"]["default_value"])),
            float(spec["K"]["minimum_value"]),
            float(spec["K"]["maximum_value"]),
            2,
        )
        if not ok:
            return
        values.update({"engine": engine, "pitch": pitch, "K": k})
        self.setPref("options", json.dumps(values))
        self._show(
            "engine {}, spacing {}, K {:g}".format(engine, f"{pitch:g} mm" if pitch > 0 else "as sliced", k)
        )

    def chooseOnSave(self):
        answer = QMessageBox.question(
            None,
            TITLE,
            "Replace the infill with stress-aligned paths every time a "
            "G-code file is saved?\n(Alternatively add the script in Extensions > "
            "Post Processing > Modify G-Code.)",
            _YES | _NO,
        )
        self.setPref("on_save", answer == _YES)

    def chooseCommand(self):
        path, _ = QFileDialog.getOpenFileName(
            None, "The 'loadpath' command in its virtual environment", os.path.expanduser("~")
        )
        if path:
            self.setPref("command", path)

    def showLastReport(self):
        folder = os.path.join(self.reportRoot(), "last-report")
        self._show(runner.report_summary(folder), report=folder)

    # -------------------------------------------------------------------------------- saving
    def _onWriteStarted(self, output_device=None):
        if not self.pref("on_save"):
            return
        scene = self._app.getController().getScene()
        gcode_dict = getattr(scene, "gcode_dict", None)
        if not gcode_dict:
            return
        plate = self._app.getMultiBuildPlateModel().activeBuildPlate
        data = gcode_dict.get(plate)
        if not data or runner.PROCESSED in data[0]:
            return
        stack = self._app.getGlobalContainerStack()
        outcome = runner.process_chunks(
            data,
            self.pref("loadcase"),
            self.options(),
            self.pref("command"),
            runner.stack_settings(stack) if stack is not None else None,
            float(self.pref("timeout") or 600),
            self.reportRoot(),
            self.pref("service_url") or "",
        )
        if outcome.ok:
            gcode_dict[plate] = outcome.chunks  # Cura's own when nothing was replaced
        else:
            data[0] = runner.error_comment(outcome.message) + data[0]
            Logger.log("e", "loadpath: %s", outcome.message)
        self._show(runner.user_message(outcome), report=outcome.report_dir)

    def _show(self, text, report=None):
        self.lastMessage = text
        Logger.log("i", "loadpath: %s", text)
        if Application.getInstance() is None:  # no Cura window (headless tests)
            return
        if self._message is not None:
            self._message.hide()
        self._message = Message(text, title=TITLE, lifetime=0)
        index = os.path.join(report, "index.html") if report else ""
        if index and os.path.isfile(index):
            self._message.addAction("open", "Open report", "", "Open the HTML report in a browser")
            self._message.actionTriggered.connect(
                lambda message, action: QDesktopServices.openUrl(QUrl.fromLocalFile(index))
            )
        self._message.show()
