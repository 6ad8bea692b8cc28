"""The mechanics model of ``loadpath compare`` and of every run's verdict: its settings and one body's solve.

One owner for how a printed body is predicted, so that the figures a run prints and those of
``loadpath compare`` on the same files are the same figures:

- the settings: :class:`~.predict.StiffnessOptions`' defaults (the beads as printed, sampled every
  0.1 mm) with the elastic ply of the file's material card (:func:`file_card`);
- the mesh: :func:`~.predict.stiffness_mesh` of the resolved body, one per body outline
  (:func:`body_mesh`), so two files of one part differ only by their beads;
- the solve and first-ply failure (:func:`solve_body`).

:func:`loadpath.stiffness.compare.evaluate_file` and :func:`loadpath.stiffness.change.predicted_change`
both call these.  A verdict on the run's own FEA mesh with beads sampled every 0.5 mm and the engine's
paths as beads disagreed with ``compare`` (L-bracket, PrusaSlicer gyroid 20 %, ``replace = sparse``:
stiffness +6.1 % against +19.7 %, failure load -13.6 % against +8.3 %).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from loadpath.loadcase.model import LoadCase
from loadpath.loadcase.resolve import ResolvedBody
from loadpath.mesh.data import MeshData
from loadpath.stiffness.cards import MaterialCard, card_for
from loadpath.stiffness.deposits import Deposits, Stack
from loadpath.stiffness.predict import Prediction, StiffnessOptions, predict, stiffness_mesh
from loadpath.stiffness.strength import Failure, first_failure

__all__ = ["file_card", "mesh_key", "body_mesh", "solve_body", "sample_count", "OUTLINE_TOL_MM"]


def file_card(
    config: Any, loadcase: LoadCase | None, options: StiffnessOptions | None = None
) -> tuple[StiffnessOptions, MaterialCard, str]:
    """The options a file is predicted with and its material card.

    Parameters
    ----------
    config : mapping
        The file's slicer configuration (``Program.config``): its filament type names the card.
    loadcase : LoadCase or None
        Its ``[material] printed`` names the card when the options do not.
    options : StiffnessOptions, optional
        Default ``StiffnessOptions()``; ``options.card`` names the card first.

    Returns
    -------
    options : StiffnessOptions
        With the card's elastic ply as the material.
    card : MaterialCard
    why : str
        Where the card came from (:func:`~.cards.card_for`).
    """
    options = StiffnessOptions() if options is None else options
    named = options.card or getattr(getattr(loadcase, "material", None), "printed", None)
    card, why = card_for(config, named)
    return replace(options, material=card.elastic), card, why


def mesh_key(rb: ResolvedBody, options: StiffnessOptions) -> tuple:
    """What :func:`body_mesh`'s mesh depends on: analysis kind, slab outlines and heights, pitch, mesh size."""
    return (
        rb.analysis,
        tuple(s.outline.wkb for s in rb.body.slabs),
        tuple((s.z0, s.z1) for s in rb.body.slabs),
        options.pitch,
        repr(options.mesh_size),
    )


OUTLINE_TOL_MM = 0.01
"""Slab outlines closer than this (Hausdorff distance, mm) are one part's: its files share a mesh.
Two PrusaSlicer 2.5 slices of one STL with other infill settings, sliced on one CPU, differ by
0.0016 mm (the open-hole specimen of ``tests/stiffness/test_compare.py``, 2026-12-05)."""


def body_mesh(rb: ResolvedBody, options: StiffnessOptions, meshes: dict[Any, MeshData] | None = None) -> MeshData:
    """The mesh a body is predicted on: :func:`~.predict.stiffness_mesh`, kept in ``meshes`` by outline.

    Two bodies with the same analysis kind and slab heights, and slab outlines within
    :data:`OUTLINE_TOL_MM`, get the very same mesh.
    """
    key = mesh_key(rb, options)
    mesh = None if meshes is None else meshes.get(key)
    if mesh is None and meshes:
        mesh = _near(key, meshes)
    if mesh is None:
        mesh = stiffness_mesh(rb, options.pitch, options.mesh_size)
    if meshes is not None:
        meshes.setdefault(key, mesh)
    return mesh


def _near(key: tuple, meshes: dict[Any, MeshData]) -> MeshData | None:
    """A mesh kept under a key that differs from ``key`` only by outlines within :data:`OUTLINE_TOL_MM`."""
    import shapely

    kind, outlines, heights, pitch, size = key
    for other, mesh in meshes.items():
        if other[0] != kind or other[2:] != (heights, pitch, size) or len(other[1]) != len(outlines):
            continue
        shapes = zip(shapely.from_wkb(list(outlines)), shapely.from_wkb(list(other[1])))
        if max(a.hausdorff_distance(b) for a, b in shapes) <= OUTLINE_TOL_MM:
            return mesh
    return None


def solve_body(
    rb: ResolvedBody, deposits: Deposits | Stack, options: StiffnessOptions, card: MaterialCard, mesh: MeshData
) -> tuple[Prediction, Failure]:
    """One body's predicted response and its first-ply failure (one solve).

    Parameters
    ----------
    rb : ResolvedBody
    deposits : Deposits or Stack
        The file's beads of the body (:func:`~.deposits.from_program`).
    options : StiffnessOptions
        From :func:`file_card`.
    card : MaterialCard
    mesh : MeshData
        From :func:`body_mesh`.
    """
    pred = predict(rb, deposits, options, mesh)
    return pred, first_failure(pred, card)


def sample_count(deposits: Deposits, options: StiffnessOptions) -> float:
    """About how many bead sample points a prediction of ``deposits`` takes (its cost grows with them).

    ``sum (ceil(length / r) + 1) (ceil(width / r) + 1)`` over the beads, ``r = options.resolution``
    (:func:`~.fields.sample_deposits` samples each bead piece so).  Measured on the shared 2-core
    machine: about 0.25-0.5 s per million points and prediction (the shipped example, 10 layers:
    7.9 million, 2 s; the same outline 20 mm thick, 100 layers: 80 million, 30-60 s).
    """
    r = options.resolution
    with np.errstate(invalid="ignore"):
        n = (np.ceil(deposits.length / r) + 1) * (np.ceil(deposits.flow_width / r) + 1)
    return float(np.sum(n[np.isfinite(n)]))
