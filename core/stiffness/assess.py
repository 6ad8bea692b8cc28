"""One call for what a printed part is worth under a load case: stiffness, failure load, safety, mass.

:func:`assess` is the small entry point other parts of loadpath call (the verdict of ``loadpath
run``, the sparse-infill engines): deposits and a resolved load case in, an :class:`Assessment` out.
It runs the bead model (:mod:`.beads`) through :func:`~.predict.predict` and the first-ply failure
of :mod:`.strength` on the same solve.

Example::

    from loadpath import gcode, geometry, loadcase, stiffness

    program = gcode.read("part.gcode")
    geo = geometry.layer_geometry(program, check=False)
    (rb,) = loadcase.resolve(loadcase.read("case.toml"), geo.bodies())
    card, _ = stiffness.card_for(program.config)
    a = stiffness.assess(rb, stiffness.from_program(program, geo.object(rb.name).code), card)
    a.stiffness, a.failure_load, a.safety_factor, a.mass, a.failure_location
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

from loadpath.fea.orthotropic import BEADS
from loadpath.loadcase.resolve import ResolvedBody
from loadpath.mesh.data import MeshData
from loadpath.stiffness.cards import PLA_CARD, MaterialCard
from loadpath.stiffness.deposits import Deposits
from loadpath.stiffness.predict import Prediction, StiffnessOptions, predict
from loadpath.stiffness.strength import Failure, first_failure

__all__ = ["Assessment", "assess", "ASSESS_RESOLUTION"]

ASSESS_RESOLUTION = 0.25
"""mm between bead samples in :func:`assess` (unless ``options`` sets one): on the shipped example the
compliance is within 0.2 % and the failure load within 2 % of the 0.1 mm that ``loadpath compare``
uses, at a third of the time (``benchmarks/bench_mechanics.py``)."""


@dataclass(frozen=True)
class Assessment:
    """Stiffness and strength of one printed body under its load case.

    Attributes
    ----------
    name : str
        Body (object) name.
    compliance : float, N mm
        ``f . u`` (lower is stiffer).
    stiffness : float, N/mm
        ``|F|^2 / compliance`` with ``|F|`` the applied load's magnitude (for one force: the force
        over the displacement of its point of application along it).
    failure_load : float, N
        Load at first-ply failure (``safety_factor x |F|``).
    safety_factor : float
        Multiple of the load case's load at which the first ply fails (< 1: it fails as loaded).
    mass : float, g
    failure_location : (3,) float, mm
    failure_mode : str
        ``along``, ``across``, ``shear`` or ``bending`` (:class:`~.strength.Failure`).
    card : MaterialCard
    prediction : Prediction
    failure : Failure
    seconds : float
        Wall time of the assessment.
    """

    name: str
    compliance: float
    stiffness: float
    failure_load: float
    safety_factor: float
    mass: float
    failure_location: tuple[float, float, float]
    failure_mode: str
    card: MaterialCard = field(repr=False)
    prediction: Prediction = field(repr=False)
    failure: Failure = field(repr=False)
    seconds: float = 0.0


def assess(
    rb: ResolvedBody,
    deposits: Deposits,
    card: MaterialCard = PLA_CARD,
    options: StiffnessOptions | None = None,
    mesh: MeshData | None = None,
) -> Assessment:
    """Assess a printed body: the bead model's stiffness and first-ply failure (module docstring).

    Parameters
    ----------
    rb : ResolvedBody
        The load case applied to the body.
    deposits : Deposits
        The body's beads (:func:`~.deposits.from_program`, :func:`~.deposits.from_toolpaths`).
    card : MaterialCard
        Default PLA (:func:`~.cards.card_for` picks the file's).
    options : StiffnessOptions, optional
        Resolution, mesh size; the material and fill model are the card's and the bead model.
        Default: :data:`ASSESS_RESOLUTION`.
    mesh : MeshData, optional
        Reuse a mesh (compare designs of one part on the very same mesh).

    Returns
    -------
    Assessment

    Raises
    ------
    LoadpathError
        From the solve or the sampling (no material inside the part).
    """
    t0 = time.perf_counter()
    opts = replace(
        options or StiffnessOptions(resolution=ASSESS_RESOLUTION), material=card.elastic, fill_model=BEADS
    )
    p = predict(rb, deposits, opts, mesh)
    f = first_failure(p, card)
    return Assessment(
        name=rb.name,
        compliance=p.compliance,
        stiffness=f.applied**2 / p.compliance if p.compliance > 0 else float("nan"),
        failure_load=f.failure_load,
        safety_factor=f.load_factor,
        mass=p.mass,
        failure_location=f.location,
        failure_mode=f.mode,
        card=card,
        prediction=p,
        failure=f,
        seconds=time.perf_counter() - t0,
    )
