# Copyright (c) loadpath contributors. MIT licence.
"""Cura plugin "Loadpath Infill": an Extensions menu and a Modify G-Code script (``scripts/``)."""

import os

from . import LoadpathInfill


def getMetaData():
    return {}


def register(app):
    # Cura's PostProcessingPlugin looks for scripts in "<each resources path>/scripts": adding the
    # plugin folder puts scripts/LoadpathScript.py into Extensions > Post Processing > Modify G-Code.
    from UM.Resources import Resources

    Resources.addSearchPath(os.path.dirname(os.path.abspath(__file__)))
    return {"extension": LoadpathInfill.LoadpathInfill(app)}
