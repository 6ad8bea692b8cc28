"""Solve in the editor: the stress field of the shown layer and a preview of the new paths.

* the stress: :func:`loadpath.fea.analyze` of the resolved body (the analysis ``run`` makes), its
  layer field sampled on a grid, decomposed into both principal stresses and directions;
* G-code: the real pipeline (:func:`loadpath.plugin.job.run_job`) writes the processed file into
  the editor's work folder; the page gets the slicer's and the new infill of one replaced layer of
  the shown region, and the predicted stiffness and first-ply failure load of both files (:func:`loadpath.stiffness.compare_files`);
* STL (not sliced yet): the path engine on the shown cross-section shrunk by two perimeters.

Failure load: loadpath has no strength model yet, so none is predicted (the answer says so).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import shapely
from loadpath.errors import LoadpathError
from loadpath.loadcase import LoadCase, ResolvedBody

__all__ = ["stress_grid", "gcode_preview", "stl_preview", "PERIMETERS_MM"]

PERIMETERS_MM = 0.9
"""How far an STL preview's fill region is inset from the outline (two 0.45 mm perimeters)."""


def _paths_json(paths: Any) -> list[list[list[float]]]:
    return [np.round(np.asarray(p.points)[:, :2], 3).tolist() for p in paths]


def stress_grid(rb: ResolvedBody, z: float, principal: str, samples: int = 46) -> tuple[Any, dict[str, Any]]:
    """Solve a resolved body and sample its stress at height ``z`` on a square grid.

    Returns
    -------
    analysis : loadpath.fea.Analysis
    grid : dict
        ``h`` (spacing, mm), ``points`` (rows ``[x, y, sigma1, sigma2, angle1]``, MPa and rad),
        ``scale`` (MPa, the field's normalising stress), ``residual`` and ``analysis`` (2d/3d).
    """
    from loadpath.fea import analyze
    from loadpath.field import principal_stresses

    analysis = analyze(rb)
    res = analysis.result
    field = analysis.field(z, principal)
    slab = rb.body.slab_at(z) or rb.body.slabs[0]
    x0, y0, x1, y1 = slab.outline.bounds
    h = max(x1 - x0, y1 - y0) / samples
    xs = np.arange(x0 + h / 2, x1, h)
    ys = np.arange(y0 + h / 2, y1, h)
    X, Y = (a.ravel() for a in np.meshgrid(xs, ys))
    inside = shapely.contains_xy(slab.outline, X, Y)
    pts = np.column_stack([X[inside], Y[inside]])
    t = field.tensor(pts)
    ok = np.all(np.isfinite(t), axis=1)
    s1, s2, e1, _ = principal_stresses(t[ok])
    rows = np.column_stack([pts[ok], s1, s2, np.arctan2(e1[:, 1], e1[:, 0])])
    return analysis, {
        "h": round(float(h), 4),
        "points": np.round(rows, 4).tolist(),
        "scale": float(field.scale),
        "residual": float(res.residual),
        "analysis": rb.analysis,
        "body": rb.name,
    }


def gcode_preview(
    part: Any, case_file: Path, lc: LoadCase, z0: float, z1: float, work: Path
) -> dict[str, Any]:
    """Run the pipeline on the G-code and compare the slicer's infill with the new one.

    Parameters
    ----------
    part : EditorPart
    case_file : Path
        The case as TOML (written by the caller into ``work``).
    z0, z1 : float, mm
        The shown region; the layer previewed is the replaced one nearest its middle.
    work : Path
        Folder for the processed file.
    """
    from loadpath import gcode
    from loadpath.plugin.job import JobRequest, run_job
    from loadpath.stiffness import compare_files
    from loadpath.stiffness.compare import infill_paths

    out = work / f"preview{part.path.suffix or '.gcode'}"
    job = run_job(JobRequest(part.path, case_file, output=out))
    new = gcode.read(out)
    geo = part.geo
    diameter = geo.filament_diameter
    layers = sorted(
        {g.layer_index for o in geo.objects for g in o.layers if z0 - 1e-6 <= g.z - g.height / 2 <= z1 + 1e-6}
    )
    mid = 0.5 * (z0 + z1)
    layers.sort(key=lambda i: abs(part.program.layers[i].z - mid))
    shown = None
    for i in layers:
        before = [p for o in geo.objects for p in infill_paths(part.program, i, o.code, diameter)]
        after = [p for o in geo.objects for p in infill_paths(new, i, o.code, diameter)]
        if len(before) != len(after) or any(
            a.points.shape != b.points.shape or not np.allclose(a.points, b.points)
            for a, b in zip(before, after, strict=False)
        ):
            shown = (i, before, after)
            break
    rows, _ = compare_files([part.path, out], lc)
    kinds = ", ".join(job.settings.replace) if job.settings is not None else "?"
    answer: dict[str, Any] = {
        "changed": job.changed,
        "warnings": job.warnings,
        "stiffness": {
            "slicer_compliance": rows[0].compliance,
            "new_compliance": rows[1].compliance,
            "relative_stiffness": rows[1].relative_stiffness,
            "relative_specific_stiffness": rows[1].relative_specific_stiffness,
            "slicer_peak_displacement": rows[0].peak_displacement,
            "new_peak_displacement": rows[1].peak_displacement,
        },
        "failure_load": {
            "slicer": rows[0].failure_load,
            "new": rows[1].failure_load,
            "relative": rows[1].relative_failure_load,
            "relative_per_mass": rows[1].relative_failure_load_per_mass,
        },
        "failure_note": None,
    }
    if shown is None:
        answer["paths_note"] = (
            f"no layer of this region was replaced (replace = {kinds}); "
            "choose other kinds under [toolpath] replace or another region"
        )
        answer["layer"] = None
        answer["paths"] = answer["slicer_paths"] = []
    else:
        i, before, after = shown
        answer["layer"] = i + 1
        answer["paths"] = _paths_json(after)
        answer["slicer_paths"] = _paths_json(before)
        answer["paths_note"] = f"layer {i + 1} (z = {part.program.layers[i].z:g} mm), replaced kinds: {kinds}"
    return answer


def stl_preview(rb: ResolvedBody, analysis: Any, lc: LoadCase, z: float) -> dict[str, Any]:
    """Run the path engine on the cross-section at ``z`` inset by two perimeters (an unsliced STL)."""
    from loadpath.engines import generate
    from loadpath.toolpath import EngineInput

    slab = rb.body.slab_at(z) or rb.body.slabs[0]
    region = slab.outline.buffer(-PERIMETERS_MM)
    if region.is_empty:
        raise LoadpathError(f"the section at z = {z:g} mm is too thin for infill inside two perimeters")
    tp = lc.toolpath
    engine = tp.engine or "swarm"
    principal = tp.principal if tp.principal not in (None, "alternate") else "max_abs"
    params = {"K": tp.K} if engine == "swarm" and tp.K is not None else {}
    paths = generate(
        engine,
        EngineInput(region, analysis.field(z, principal), tp.pitch or 0.45, rb.load_entry(z)),
        **params,
    )
    return {
        "paths": _paths_json(paths.paths),
        "slicer_paths": [],
        "layer": None,
        "paths_note": (
            f"{engine} paths at pitch {tp.pitch or 0.45:g} mm on the section at z = {z:g} mm "
            "(STL: slice it for the real paths and the predicted stiffness)"
        ),
        "stiffness": None,
        "failure_load": None,
        "failure_note": "no failure load for an STL: slice it for the real paths and their first-ply failure",
    }
