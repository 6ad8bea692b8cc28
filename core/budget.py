"""Budgets of the stages whose cost grows with the input: geometry, meshing and the engines.

The reader's bounds (:mod:`loadpath.gcode.bounds`) keep every coordinate on the bed, but a file can
still ask for unbounded work inside it: a bead width of a thousandth of a millimetre makes the
geometry's nearest-lines split sample every line a thousand times more densely, a pitch of 0.05 mm
on a large part gives the mesh and the engines millions of cells.  Each stage checks its own size
against a budget here **before** it allocates, and stops with one line naming the layer (or body),
what is too big and what to do::

    layer 12 (z = 2.4 mm), object 'part': 3,200,000 samples of the nearest-lines split exceed the
    budget of 1,000,000; ...

The defaults are far above every real slicer part in the tests (``benchmarks/bench_budget.py``
prints the largest real figure beside each budget), so only a damaged or hostile file meets them.

One owner: every budget is a module constant, read at call time (tests lower them with
``monkeypatch`` to hit a budget with a small real part; the behaviour is the same at any value).
"""

from __future__ import annotations

from loadpath.errors import BudgetError

__all__ = [
    "LAYER_SEGMENTS",
    "SPLIT_SAMPLES",
    "MESH_ELEMENTS",
    "MESH_NODES",
    "ENGINE_CELLS",
    "DIRECT_BYTES",
    "MESH_SECONDS",
    "MESH_SECONDS_PER_ELEMENT",
    "WALL_PER_CPU",
    "WALL_SECONDS",
    "check",
    "mesh_elements_estimate",
    "mesh_seconds",
    "tets_estimate",
]

LAYER_SEGMENTS = 2_000_000
"""Extrusion segments of one object in one layer that the geometry turns into walls, beads and
islands (the committed real files: at most 1,528, the PrusaSlicer 2.7.4 plant sign)."""

SPLIT_SAMPLES = 100_000
"""Samples of the centre lines in one island's nearest-lines (Voronoi) split of sparse blocks.

The split costs about a millisecond per sample (GEOS's snap-rounded union of the cells; 12,800
samples took 14 s on the shared test machine), so this is a minute or two.  The committed real
files need at most 833 (the OrcaSlicer P1S cube, layer 95); a 250 x 250 mm island
of 20 % sparse infill in two blocks would have about 60,000; a bead width shrunk a thousandfold
(a damaged E) millions."""

MESH_ELEMENTS = 1_000_000
"""Estimated triangles of a 2D mesh before gmsh runs (from the area, the refined lengths and the
element sizes; real parts: below 20,000)."""

MESH_NODES = 3_000_000
"""Nodes of the mesh gmsh returned (2D or 3D), before the stiffness matrix is assembled (real parts:
below 100,000; the 3D default mesh is coarsened to 60,000 tetrahedra)."""

MESH_SECONDS = 10.0
"""CPU seconds gmsh's mesher may take on any mesh, before the share that grows with its elements
(:func:`mesh_seconds`).  gmsh has no time limit of its own and loops for ever on some outlines."""

MESH_SECONDS_PER_ELEMENT = 2e-4
"""CPU seconds per estimated element on top of :data:`MESH_SECONDS`.  gmsh's Frontal-Delaunay with
its optimisation took 22, 39 and 60 us per triangle for 12,700, 50,000 and 199,000 triangles (a
150 x 36 mm plate with a hole, shared test machine), so this leaves a margin of three or more; the
largest mesh the budget admits (:data:`MESH_ELEMENTS`) gets 210 s."""

WALL_PER_CPU = 10.0
"""Wall seconds allowed per CPU second of a time budget, plus :data:`WALL_SECONDS`: only for a
child that blocks without using CPU.  A busy shared machine stretches wall time (the 199,000
triangles above took 12 s CPU in 55 s wall at a load of 12 on 2 cores)."""

WALL_SECONDS = 60.0
"""Wall seconds added to every wall-time limit (:data:`WALL_PER_CPU`)."""

DIRECT_BYTES = 2**30
"""Expected bytes of SuperLU's factors (:func:`loadpath.fea.solver.direct_fill_bytes`) above which
the FEA is not solved directly: AMG-CG instead, and no direct fall-back when CG misses its
tolerance.  A process needs about twice the estimate at its peak (313,000 2D dofs: 756 MB of
factors, 1.8 GB peak RSS), so this keeps a solve within a 4 GiB address space.  Every system
within :data:`loadpath.fea.solver.DIRECT_LIMIT` is below it (150,000 2D dofs: 354 MB; 15,000 3D
dofs: 135 MB); the fall-backs meet it at about 400,000 2D and 68,000 3D dofs."""

ENGINE_CELLS = 500_000
"""One unit's fill region in pitch cells (area / pitch^2): the engines' path samples and QP
unknowns grow with it.  A 256 x 256 mm bed (Bambu Lab X1) filled solid at 0.42 mm is 371,000;
the shipped specimen at the smallest ``--pitch`` (0.05 mm) about 2 million."""


def check(value: float, limit: float, where: str, what: str, fix: str) -> None:
    """Raise :class:`BudgetError` when ``value`` exceeds ``limit``.

    Parameters
    ----------
    value, limit : float
        The stage's size and its budget (same unit, counted before the work).
    where : str
        ``"layer 3 (z = 0.6 mm), object 'part'"``, or ``""`` when the caller adds it
        (:meth:`BudgetError.at`).
    what : str
        What is counted, plural (``"samples of the nearest-lines split"``).
    fix : str
        What the user can do.
    """
    if not value <= limit:  # NaN too
        head = f"{where}: " if where else ""
        raise BudgetError(f"{head}{value:,.0f} {what} exceed the budget of {limit:,.0f}; {fix}")


def mesh_elements_estimate(area: float, h: float, h_min: float, grading: float,
                           refined_length: float, corners: int) -> float:
    """Triangles a graded 2D mesh of these sizes will have, before meshing.

    A triangle of edge ``s`` covers ``sqrt(3)/4 s^2``, so a region of size ``s`` holds about
    ``2.31 / s^2`` of them per mm^2.  The size grows by ``grading`` per mm away from a refined
    line (length ``refined_length``) or corner, from ``h_min`` to ``h``; integrated over the band
    around the lines (``L dd``) and the discs around the corners (``2 pi d dd``), plus the bulk at
    ``h``.  On the shipped specimen 1,645 against gmsh's 1,972 (bands of neighbouring features
    overlap, and gmsh's Frontal-Delaunay packs a little denser than equilateral).

    Parameters
    ----------
    area : float, mm^2
    h, h_min : float, mm
        Bulk and smallest element size.
    grading : float
        Size growth per mm.
    refined_length : float, mm
        Length of the lines refined to ``h_min`` (holes, loaded and supported boundary).
    corners : int
        Refined points (re-entrant corners).

    Returns
    -------
    float
    """
    import math

    k = 4.0 / math.sqrt(3.0)
    h_min = min(h_min, h)
    bulk = k * area / h**2
    if h_min >= h or grading <= 0:
        return bulk + k * refined_length / h  # one row of elements along the lines at most
    band = k * refined_length / grading * (1.0 / h_min - 1.0 / h)
    disc = 2 * math.pi * k / grading**2 * (math.log(h / h_min) + h_min / h - 1.0)
    return bulk + band + corners * disc


def mesh_seconds(elements: float) -> float:
    """CPU seconds gmsh may spend on a mesh of about ``elements`` elements.

    ``MESH_SECONDS + MESH_SECONDS_PER_ELEMENT * elements``; NaN counts as the budget's limit.
    """
    if not elements >= 0:
        elements = MESH_ELEMENTS
    return MESH_SECONDS + MESH_SECONDS_PER_ELEMENT * min(float(elements), 10.0 * MESH_ELEMENTS)


def tets_estimate(volume: float, h: float) -> float:
    """Tetrahedra of edge ``h`` (mm) filling ``volume`` (mm^3): a regular one holds ``h^3 / (6 sqrt 2)``."""
    import math

    return 6.0 * math.sqrt(2.0) * max(volume, 0.0) / max(h, 1e-9) ** 3
