# Copyright (c) loadpath contributors. MIT licence.
"""Cura post-processing script (Extensions > Post Processing > Modify G-Code > Add a script >
"Loadpath stress-aligned infill"): replaces infill with stress-aligned paths.

A thin shell over ``loadpath_runner`` (one folder up): it reads its settings and Cura's resolved
global and extruder settings, runs loadpath out of process and returns the new chunk list. Cura
logs and swallows script exceptions, so a failure is shown as a Cura message and written as a
comment at the top of the G-code, and the slicer's G-code is kept.
"""

import importlib.util
import json
import os
import sys

from ..Script import Script  # Cura's PostProcessingPlugin.Script

_RUNNER = "_loadpath_cura_runner"


def _runner():
    """The plugin's ``loadpath_runner`` module, loaded by path (scripts are loaded as loose files)."""
    if _RUNNER not in sys.modules:
        path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "loadpath_runner.py")
        spec = importlib.util.spec_from_file_location(_RUNNER, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[_RUNNER] = module
    return sys.modules[_RUNNER]


class LoadpathScript(Script):
    """Stress-aligned infill (loadpath) as a Modify G-Code script."""

    def getSettingDataString(self):
        return json.dumps(_runner().script_setting_data())

    # Cura's state: overridden by nothing in Cura; headless callers (tests) may override them.
    def cura_stacks(self):
        """(global stack, extruder stacks) of the running Cura, or (None, None) without one."""
        try:
            from cura.CuraApplication import CuraApplication

            app = CuraApplication.getInstance()
            stack = app.getGlobalContainerStack() if app is not None else None
        except Exception:
            return None, None
        return stack, (list(stack.extruderList) if stack is not None else None)

    def preference(self, key):
        """A preference the Extensions menu stored (``loadpath/<key>``), or ''."""
        try:
            from UM.Application import Application

            app = Application.getInstance()
            if app is None:
                return ""
            return app.getPreferences().getValue("loadpath/" + key) or ""
        except Exception:
            return ""

    def report_root(self):
        """Where the last report is kept (Cura's cache folder)."""
        try:
            from UM.Resources import Resources

            return os.path.join(Resources.getCacheStoragePath(), "loadpath")
        except Exception:
            import tempfile

            return os.path.join(tempfile.gettempdir(), "loadpath-cura")

    def tell_user(self, text, title="Loadpath infill"):
        """A Cura message; logged when there is no Cura window."""
        try:
            from UM.Logger import Logger

            Logger.log("w", "loadpath: %s", text)
            from UM.Application import Application

            if Application.getInstance() is not None:
                from UM.Message import Message

                Message(text, title=title, lifetime=0).show()
        except Exception:
            pass

    def execute(self, data):
        r = _runner()
        if not data or r.PROCESSED in data[0]:
            return data
        get = self.getSettingValueByKey
        stack, extruders = self.cura_stacks()
        outcome = r.process_chunks(
            data,
            loadcase=get("loadcase") or self.preference("loadcase"),
            options=r.options_from(get),
            command=get("loadpath_command") or self.preference("command"),
            cura_settings=r.stack_settings(stack, extruders) if stack is not None else None,
            timeout=float(get("timeout") or 600),
            report_root=self.report_root() if get("report") else None,
            service_url=get("service_url") or "",
        )
        self.tell_user(r.user_message(outcome))
        if not outcome.ok:
            data = list(data)
            data[0] = r.error_comment(outcome.message) + data[0]
            return data
        return outcome.chunks
