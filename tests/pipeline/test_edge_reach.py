"""The new solid infill reaches the loaded end face as the slicer's does (real PrusaSlicer 2.5 slice).

A pull spread over a grip zone fades towards the part's end face, and there the larger principal
stress turns along the face in the last millimetre.  The level sets were cut at that turn and
stopped up to 0.75 mm short of the face on every replaced layer, and ``loadpath compare`` put the
first ply's failure of a 100-layer specimen at the void they left (0.255x the slicer's failure load;
``loadpath.engines.levelset.EDGE_SKIN``).
"""

from __future__ import annotations

import numpy as np
from cases import GRIP_PULL
from loadpath import gcode
from loadpath.gcode import Role
from loadpath.plugin.job import JobRequest, run_job

_INFILL = (int(Role.SOLID_INFILL), int(Role.SPARSE_INFILL))


def _reach(program, layer: int, y0: float) -> float | None:
    """How far in x the infill of ``layer`` reaches between ``y0`` and ``y0 + 1`` mm (None: none there)."""
    m = program.moves
    k = ~m["travel"] & np.isin(m["role"], _INFILL) & (m["layer"] == layer)
    y = 0.5 * (m["y0"][k] + m["y1"][k])
    x = np.maximum(m["x0"][k], m["x1"][k])
    band = (y >= y0) & (y < y0 + 1.0)
    return float(x[band].max()) if band.any() else None


def test_solid_infill_reaches_the_end_face_of_a_grip_zone_on_every_replaced_layer(sliced, tmp_path):
    src = sliced("prusa", "ohs", "solid")
    case = tmp_path / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    out = tmp_path / "out.gcode"
    res = run_job(JobRequest(src, case, output=out, cli={"jobs": 1, "cache": False}))
    assert res.error is None and res.pipeline.check.problems == []
    slicer, ours = gcode.read(src), gcode.read(out)
    layers = sorted({b.layer for b in res.pipeline.splice.blocks})
    assert len(layers) >= 6, layers
    m = slicer.moves
    inf = ~m["travel"] & np.isin(m["role"], _INFILL)
    lo, hi = float(np.min(m["y0"][inf])), float(np.max(m["y0"][inf]))
    short = []
    for layer in layers:
        for y0 in np.arange(lo + 2.0, hi - 2.0, 1.0):  # the corners' bands aside
            a, b = _reach(slicer, layer, y0), _reach(ours, layer, y0)
            if a is not None and b is not None and a > m["x1"][inf].max() - 3.0:
                short.append(a - b)
    # the engine keeps its ends a quarter bead inside the region: a tenth of a millimetre, no more
    assert short and max(short) < 0.25, (len(short), max(short))
