"""K = 0 (spacing only, no pull towards the stress) is a value the settings accept: it must run.

On the specimen's real field a fill swarm that no boundary agent anchors could slide as a whole at
no cost; the QP was singular and OSQP stopped at its iteration limit (a SolverError that blamed the
field).  The environment weight's floor (:data:`loadpath.engines.swarm.chain.WEIGHT_FLOOR`) pins it.
"""

from __future__ import annotations

from loadpath import metrics as M
from loadpath.engines.swarm import generate
from loadpath.engines.swarm.entry import load_entry
from loadpath.fea import analyze
from loadpath.loadcase import Body, parse, resolve
from loadpath.toolpath import EngineInput
from shapely.geometry import Point, box

PITCH = 0.4
CASE = """
version = 1
[[supports]]
name = "clamp"
where = { side = "x_min", within = 10.0 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { side = "x_max", within = 0.5 }
force = [1000.0, 0.0, 0.0]
"""


def test_k_zero_lays_an_evenly_spaced_layer_on_the_specimen():
    region = box(0, 0, 150, 36).difference(Point(75, 18).buffer(3, quad_segs=64))
    (rb,) = resolve(parse(CASE), [Body.from_layers("ohs", [(0.0, 2.0, region)])])
    field = analyze(rb, pitch=PITCH).field(1.0)
    inp = EngineInput(region=region, field=field, pitch=PITCH, load_entry=load_entry(rb, 1.0))
    tp = generate(inp, K=0.0)
    assert tp.stats["qp_solves"] == tp.stats["qp_exact"] + tp.stats.get("qp_osqp_solved", 0)
    cov = M.coverage(tp, region)
    assert cov.coverage >= 0.98 and cov.overlap <= 0.02, cov
    assert M.crossings(tp) == 0
    spacing = M.spacing(tp, PITCH, definition="next")
    # spacing only: at least as even as the default K = 5
    assert spacing.variance <= M.spacing(generate(inp, K=5.0), PITCH, definition="next").variance
