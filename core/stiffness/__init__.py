"""Predicted stiffness of printed parts: an anisotropic FEA of the material a G-code deposits.

Typical use::

    from loadpath import gcode, geometry, loadcase, stiffness

    program = gcode.read("part.gcode")
    geo = geometry.layer_geometry(program, check=False)
    (rb,) = loadcase.resolve(loadcase.read("case.toml"), geo.bodies())
    dep = stiffness.from_program(program, geo.object(rb.name).code)
    p = stiffness.predict(rb, dep)                # Prediction: compliance, peak displacement, mass, ...
    top = stiffness.ceiling(rb, mesh=p.mesh)      # every element filled along its principal stress

    rows = stiffness.compare_files(["a.gcode", "b.gcode"], "case.toml")   # what ``loadpath compare`` prints
    card, _ = stiffness.card_for(program.config)  # PLA / PETG / ABS from the file's filament type
    a = stiffness.assess(rb, dep, card)           # stiffness, failure load, safety factor, mass, where

Model: :mod:`loadpath.fea.orthotropic` (printed ply, fill models, orientation averaging); the beads
as printed (fusion, bead ends, crossings): :mod:`.beads`; beads to elements: :mod:`.fields`; solve and
ceiling: :mod:`.predict`; first-ply failure: :mod:`.strength`; material cards: :mod:`.cards`; the
one-call entry: :mod:`.assess`; files: :mod:`.compare`.
"""

from loadpath.stiffness import cards
from loadpath.stiffness.assess import Assessment, assess
from loadpath.stiffness.cards import CARDS, MaterialCard, Strengths, card_for
from loadpath.stiffness.compare import CompareRow, FileResult, compare_files, evaluate_file, gains
from loadpath.stiffness.deposits import PART_ROLES, Deposits, from_program, from_toolpaths
from loadpath.stiffness.fields import DEFAULT_RESOLUTION, PlyFields, sample_deposits
from loadpath.stiffness.predict import (
    Prediction,
    StiffnessOptions,
    ceiling,
    material_matrices,
    predict,
    solve_printed,
    stiffness_mesh,
)

__all__ = [
    "assess",
    "Assessment",
    "cards",
    "CARDS",
    "MaterialCard",
    "Strengths",
    "card_for",
    "Deposits",
    "from_program",
    "from_toolpaths",
    "PART_ROLES",
    "PlyFields",
    "sample_deposits",
    "DEFAULT_RESOLUTION",
    "StiffnessOptions",
    "Prediction",
    "predict",
    "ceiling",
    "stiffness_mesh",
    "material_matrices",
    "solve_printed",
    "CompareRow",
    "FileResult",
    "evaluate_file",
    "compare_files",
    "gains",
]
