"""Compare G-code files under one load case: what ``loadpath compare`` computes.

For each file: parse it, derive the part outline per layer (:mod:`loadpath.geometry`), apply the
load case (:func:`loadpath.loadcase.resolve`), and for each body the load case applies to predict
the compliance and peak displacement from the file's own beads (:func:`~.predict.predict`).  Beside
them, two path metrics of the file's infill (every infill role, each layer against that layer's
isotropic stress field, as the engines see it): the stress alignment ``beta`` (swarm paper Eq. 14,
:func:`loadpath.metrics.alignment`, pooled over the layers with its virtual-mass weights) and the
bead coverage of the infill domain (:func:`loadpath.metrics.coverage` with each bead's flow width,
pooled by area over at most four layers spread over the height: the union of the beads is the
expensive part; :func:`_coverage_layers`).  In 3D, beta is pooled over at most 24 layers.

Files whose bodies have the same outlines (within :data:`~.model.OUTLINE_TOL_MM`, 0.01 mm) are
solved on the very same mesh, so two files of one part differ only by their beads.  Relative
stiffness is against the first file: ``compliance_first / compliance``; per mass,
``(compliance * mass)_first / (compliance * mass)``.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from loadpath import metrics
from loadpath.errors import LoadCaseError, LoadpathError
from loadpath.fea.analysis import Analysis, analyze
from loadpath.gcode.flavors import Role
from loadpath.gcode.model import Program
from loadpath.loadcase.model import LoadCase
from loadpath.loadcase.resolve import ResolvedBody, resolve
from loadpath.mesh.data import MeshData
from loadpath.stiffness.cards import PLA_CARD, MaterialCard
from loadpath.stiffness.deposits import from_program
from loadpath.stiffness.model import body_mesh, file_card, solve_body
from loadpath.stiffness.predict import Prediction, StiffnessOptions
from loadpath.stiffness.strength import Failure
from loadpath.toolpath import Path

__all__ = ["FileResult", "CompareRow", "evaluate_file", "compare_files", "gains", "infill_paths", "row"]
__all__ += ["ROW_KEYS", "MECHANICS_KEYS"]

ROW_KEYS = ("file", "compliance", "peak_displacement", "relative_stiffness", "beta", "coverage")
"""The keys every row has (interface.md); rows also carry :data:`MECHANICS_KEYS`."""

MECHANICS_KEYS = (
    "mass",
    "relative_specific_stiffness",
    "relative_stiffness_per_mass",
    "failure_load",
    "safety_factor",
    "relative_failure_load",
    "relative_failure_load_per_mass",
    "failure_location",
    "failure_mode",
)
"""Keys added by the strength model (issue 14): failure load N, safety factor, per mass, where."""

_INFILL = np.array([int(r) for r in Role if r.is_infill], dtype=np.int64)
_MAX_BETA_LAYERS = 24
_MAX_COVERAGE_LAYERS = 4


def _coverage_layers(n: int, most: int = _MAX_COVERAGE_LAYERS) -> set[int]:
    """Which of ``n`` layers the coverage is measured on: at most ``most``, each in the middle of its
    share of the height.

    Evenly spread from the first to the last (before 2026-12-07), half of the four were the first and
    the last layer, the slicer's bottom and top skins on nearly every part, whatever its height: on
    the printability bench's 12-layer bar, replaced at PrusaSlicer 100 %, 0.9835 where the replaced
    layers themselves cover 0.9707 (``benchmarks/printability_results.md``, twenty-seventh round).

    Examples
    --------
    >>> sorted(_coverage_layers(12)), sorted(_coverage_layers(3))
    ([1, 4, 7, 10], [0, 1, 2])
    """
    k = min(n, most)
    return set(((np.arange(k) + 0.5) * n / k).astype(int).tolist()) if k > 0 else set()


@dataclass(frozen=True)
class FileResult:
    """Everything computed for one file.

    Attributes
    ----------
    file : str
    predictions : tuple of Prediction
        One per body the load case applies to.
    isotropic : tuple of Analysis
        The load case's isotropic analysis of each body (its stress field is the one the paths
        are measured against).
    beta : float
        Pooled stress alignment of the infill (NaN when the file has no infill in the field).
    coverage : float
        Pooled coverage of the infill domain by infill beads, in [0, 1].
    """

    file: str
    predictions: tuple[Prediction, ...]
    isotropic: tuple[Analysis, ...] = field(repr=False)
    beta: float
    coverage: float
    failures: tuple[Failure, ...] = ()
    card: MaterialCard = PLA_CARD
    card_why: str = "default"

    @property
    def weakest(self) -> Failure | None:
        """The body's failure with the smallest safety factor (None without a strength result)."""
        return min(self.failures, key=lambda f: f.load_factor) if self.failures else None

    @property
    def failure_load(self) -> float:
        """Failure load of the weakest body, N."""
        w = self.weakest
        return w.failure_load if w is not None else float("nan")

    @property
    def safety_factor(self) -> float:
        """Smallest safety factor over the bodies."""
        w = self.weakest
        return w.load_factor if w is not None else float("nan")

    @property
    def compliance(self) -> float:
        """Summed over the bodies, N mm."""
        return float(sum(p.compliance for p in self.predictions))

    @property
    def peak_displacement(self) -> float:
        """Largest over the bodies, mm."""
        return float(max(p.peak_displacement for p in self.predictions))

    @property
    def mass(self) -> float:
        """Material of the bodies, g."""
        return float(sum(p.mass for p in self.predictions))


@dataclass(frozen=True)
class CompareRow:
    """One line of the comparison table.

    Attributes
    ----------
    file : str
    compliance : float, N mm
    peak_displacement : float, mm
    relative_stiffness : float
        ``compliance of the first file / compliance``.
    beta : float
    coverage : float
    mass : float, g
    relative_specific_stiffness : float
        ``(compliance * mass) of the first file / (compliance * mass)``: the stiffness at equal
        mass (this file scaled to the first file's mass).
    failure_load : float, N
        Load at first-ply failure (:mod:`loadpath.stiffness.strength`).
    safety_factor : float
        Failure load over the applied load.
    relative_failure_load : float
        Against the first file.
    relative_failure_load_per_mass : float
        ``(failure_load / mass) / (failure_load / mass) of the first file``.
    failure_location : (3,) tuple of float, mm, or None
    failure_mode : str
    """

    file: str
    compliance: float
    peak_displacement: float
    relative_stiffness: float
    beta: float
    coverage: float
    mass: float
    relative_specific_stiffness: float
    failure_load: float = float("nan")
    safety_factor: float = float("nan")
    relative_failure_load: float = float("nan")
    relative_failure_load_per_mass: float = float("nan")
    failure_location: tuple[float, float, float] | None = None
    failure_mode: str = ""

    @property
    def relative_stiffness_per_mass(self) -> float:
        """Same as ``relative_specific_stiffness`` (the name issue 14 gives it)."""
        return self.relative_specific_stiffness

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready mapping (NaN becomes None)."""
        out: dict[str, Any] = {}
        for k in (*ROW_KEYS, *MECHANICS_KEYS):
            v = getattr(self, k)
            if isinstance(v, tuple):
                v = [round(float(x), 3) for x in v]
            out[k] = None if isinstance(v, float) and not np.isfinite(v) else v
        return out


def infill_paths(program: Program, layer: int, object_code: int, diameter: float) -> list[Path]:
    """Return the infill extrusions of one object in one layer as polylines (vertex pitch = flow width)."""
    from loadpath.geometry import flow_widths

    sl = slice(*_layer_rows(program, layer))
    m = program.moves[sl]
    keep = m["extrude"] & np.isin(m["role"], _INFILL) & (m["object"] == object_code)
    fw = flow_widths(m, diameter)
    keep &= np.isfinite(fw) & (fw > 0)
    r = np.flatnonzero(keep)
    if len(r) == 0:
        return []
    a = np.column_stack([m["x0"][r], m["y0"][r]])
    b = np.column_stack([m["x1"][r], m["y1"][r]])
    brk = np.ones(len(r), dtype=bool)
    brk[1:] = (r[1:] != r[:-1] + 1) | (np.hypot(*(a[1:] - b[:-1]).T) > 1e-6)
    starts = np.flatnonzero(brk)
    out = []
    for s, e in zip(starts, [*starts[1:], len(r)], strict=True):
        pts = np.vstack([a[s:e], b[e - 1 : e]])
        w = fw[r[s:e]]
        out.append(Path(pts, np.append(w, w[-1])))
    return out


def _layer_rows(program: Program, layer: int) -> tuple[int, int]:
    lay = program.layers[layer]
    rows = program.move_rows(lay.start, lay.stop)
    return rows.start, rows.stop


def _path_metrics(
    program: Program, geo_obj: Any, rb: ResolvedBody, iso: Analysis, diameter: float, pitch: float
) -> tuple[float, float, float, float]:
    """Pooled (sum m cos, sum m, covered area, domain area) of a body's infill."""
    layers = [g for g in geo_obj.layers if not g.domain.is_empty]
    if rb.analysis == "3d" and len(layers) > _MAX_BETA_LAYERS:
        layers = [layers[i] for i in np.linspace(0, len(layers) - 1, _MAX_BETA_LAYERS).round().astype(int)]
    cov_at = _coverage_layers(len(layers))
    mc = ms = cov = area = 0.0
    for i, g in enumerate(layers):
        paths = infill_paths(program, g.layer_index, geo_obj.code, diameter)
        dom = g.domain
        if i in cov_at:
            area += dom.area
            if paths:
                cov += metrics.coverage(paths, dom).coverage * dom.area
        if not paths:
            continue
        z0, z1 = rb.body.z_range
        zq = float(np.clip(g.z - 0.5 * g.height, z0, z1))
        al = metrics.alignment(paths, iso.field(zq), pitch, region=dom)
        mc += float(np.sum(al.mass * al.cos))
        ms += float(np.sum(al.mass))
    return mc, ms, cov, area


def evaluate_file(
    source: str | os.PathLike[str] | Program,
    loadcase: LoadCase,
    options: StiffnessOptions | None = None,
    meshes: dict[Any, MeshData] | None = None,
    name: str | None = None,
    metrics: bool = True,
) -> FileResult:
    """Predict one file's stiffness under a load case, with its path metrics.

    Parameters
    ----------
    source : path or Program
    loadcase : LoadCase
    options : StiffnessOptions
    meshes : dict, optional
        Cache of meshes by body outline; pass the same dict for every file of a comparison.
    name : str, optional
        Label of the file in the result (default the path).
    metrics : bool
        Also the path metrics (an isotropic analysis per body, then beta and coverage); False: the
        mechanics only (``isotropic`` empty, ``beta`` and ``coverage`` NaN), for a caller that ranks
        files by stiffness and failure load (``density = "auto"``), which reads the file's layer
        geometry for the part's body alone (``layer_geometry(outlines_only=True)``: the same body).

    Returns
    -------
    FileResult

    Raises
    ------
    LoadpathError
        Unreadable G-code, a load case that does not fit the part, a failed solve.
    """
    from loadpath import gcode, geometry

    if isinstance(source, Program):
        program = source
    else:
        try:
            program = gcode.read(source)
        except OSError as exc:
            raise LoadpathError(f"cannot read {source}: {exc.strerror or exc}; check the path") from None
    label = name if name is not None else (str(source) if not isinstance(source, Program) else "program")
    options, card, card_why = file_card(program.config, loadcase, options)
    geo = geometry.layer_geometry(program, check=False, outlines_only=not metrics)  # the body alone
    rbs = resolve(loadcase, geo.bodies())
    diameter = geo.filament_diameter
    preds, isos, fails = [], [], []
    mc = ms = cov = area = 0.0
    for rb in rbs:
        obj = geo.object(rb.name)
        mesh = body_mesh(rb, options, meshes)
        pred, fail = solve_body(rb, from_program(program, obj.code, diameter), options, card, mesh)
        preds.append(pred)
        fails.append(fail)
        if not metrics:
            continue
        iso = analyze(rb, mesh=mesh)
        isos.append(iso)
        a, b, c, d = _path_metrics(program, obj, rb, iso, diameter, options.pitch)
        mc, ms, cov, area = mc + a, ms + b, cov + c, area + d
    beta = mc / ms if ms > 0 else float("nan")
    return FileResult(
        label,
        tuple(preds),
        tuple(isos),
        beta,
        cov / area if area > 0 else float("nan"),
        tuple(fails),
        card,
        card_why,
    )


def compare_files(
    files: Sequence[str | os.PathLike[str]],
    loadcase: LoadCase,
    options: StiffnessOptions | None = None,
) -> tuple[list[CompareRow], list[FileResult]]:
    """Evaluate several files under one load case, relative to the first.

    Returns
    -------
    rows : list of CompareRow
    results : list of FileResult
    """
    if not files:
        raise LoadCaseError("compare needs at least one G-code file")
    options = StiffnessOptions() if options is None else options
    meshes: dict[Any, MeshData] = {}
    results = [evaluate_file(f, loadcase, options, meshes) for f in files]
    n0 = len(results[0].predictions)
    for r in results[1:]:
        if len(r.predictions) != n0:
            raise LoadCaseError(
                f"{r.file}: the load case applies to {len(r.predictions)} object(s), "
                f"but to {n0} in {results[0].file}; "
                "compare files of the same part (or name the object with object = in the load case)"
            )
    ref = results[0]
    rows = [row(r, ref) for r in results]
    return rows, results


def row(r: FileResult, ref: FileResult) -> CompareRow:
    """The comparison row of one file against the reference file."""
    w = r.weakest
    return CompareRow(
        r.file,
        r.compliance,
        r.peak_displacement,
        ref.compliance / r.compliance,
        r.beta,
        r.coverage,
        r.mass,
        (ref.compliance * ref.mass) / (r.compliance * r.mass),
        r.failure_load,
        r.safety_factor,
        r.failure_load / ref.failure_load,
        (r.failure_load / r.mass) / (ref.failure_load / ref.mass),
        w.location if w is not None else None,
        w.mode if w is not None else "",
    )


def gains(
    baseline: Prediction | FileResult, design: Prediction | FileResult, top: Prediction | FileResult
) -> dict[str, float]:
    """Gains of a design over a baseline, absolute and per mass, and as shares of the ceiling's gains.

    ``gain = c_base / c_design - 1``; per mass ``(c m)_base / (c m)_design - 1``; shares are the
    design's gain over the ceiling's gain (``top``) on the same basis.
    """
    cb, cd, ct = baseline.compliance, design.compliance, top.compliance
    mb, md, mt = baseline.mass, design.mass, top.mass
    g = cb / cd - 1.0
    gt = cb / ct - 1.0
    gs = (cb * mb) / (cd * md) - 1.0
    gst = (cb * mb) / (ct * mt) - 1.0
    return {
        "gain": g,
        "ceiling_gain": gt,
        "share": g / gt if gt != 0 else float("nan"),
        "specific_gain": gs,
        "ceiling_specific_gain": gst,
        "specific_share": gs / gst if gst != 0 else float("nan"),
    }
