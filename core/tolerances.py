"""One place for tolerances and unit conventions.

Units: lengths in mm, time in s, forces in N, stresses and moduli in MPa, feedrates in mm/min only
where G-code is read or written.  No naked epsilons elsewhere in the package: import :data:`TOL`.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Tolerances", "TOL"]


@dataclass(frozen=True)
class Tolerances:
    """Tolerances shared by every module.

    Attributes
    ----------
    length_mm : float
        Two lengths closer than this are equal (G-code prints 3 decimals).
    e_mm : float
        Two extrusion amounts closer than this are equal (G-code prints 5 decimals).
    angle_rad : float
        Two directions closer than this are parallel.
    snap_mm : float
        Perimeter loops whose ends are closer than this are snapped shut.
    region_compare_mm : float
        Two layer regions whose symmetric difference, divided by their perimeter, is below this
        are the same region (so rounding does not make every layer distinct).
    qp_eps_abs, qp_eps_rel : float
        OSQP tolerances, in the scaled coordinates of the swarm QPs (displacements / step h).
    fea_residual : float
        Largest accepted relative residual ``||K u - f|| / ||f||`` of an FEA solve.
    anisotropy_rel : float
        A principal direction is undefined where ``sigma1 - sigma2`` is below this fraction of the
        field's normalising stress.
    arc_chord_mm : float
        G2/G3 arcs read from G-code are sampled into chords that deviate from the arc by at most this.
    loop_close_rel : float
        A perimeter chain whose two ends are closer than this many bead widths is a closed loop
        (PrusaSlicer clips every loop end by 0.15 x the nozzle diameter, 0.06 mm on a 0.4 nozzle; the
        beads of a gap narrower than one bead width touch, so the wall is closed).
    region_reuse_mm : float
        A layer whose region's boundary lies within this of its engine run's representative's
        (Hausdorff distance, both ways) prints the representative's linked runs as they are, instead
        of the paths clipped to its own region and linked again (:func:`loadpath.pipeline.paths.reuses`).
        The regions of the 1000-layer specimen's identical layers lie 9 um apart in the median and
        28 um at the 90th percentile (PrusaSlicer simplifies its paths within ``gcode_resolution``,
        12.5 um, and rounds to 1 um; then the measured infill overlap): 0.05 mm takes them all, a
        ninth of a 0.45 mm bead and half of what PrusaSlicer's own infill runs into the perimeters
        (``infill_overlap``, 0.1 mm); a layer lacking a sliver (0.75 mm from its neighbours) is cut.
    region_check_rel : float
        An infill block's centre lines must lie inside its derived region within this many flow widths
        (slicers run infill lines into the innermost perimeter: PrusaSlicer's ``infill_overlap``,
        Cura's ``infill_overlap`` / ``skin_overlap``, up to about a third of a bead).
    """

    length_mm: float = 1e-6
    e_mm: float = 1e-5
    angle_rad: float = 1e-9
    snap_mm: float = 0.05
    region_compare_mm: float = 0.02
    qp_eps_abs: float = 1e-7
    qp_eps_rel: float = 1e-7
    fea_residual: float = 1e-8
    anisotropy_rel: float = 1e-3
    arc_chord_mm: float = 0.005
    loop_close_rel: float = 1.0
    region_check_rel: float = 0.5
    region_reuse_mm: float = 0.05


TOL = Tolerances()
