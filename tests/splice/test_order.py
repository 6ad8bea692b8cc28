"""order_paths keeps its last orders under the path ends and the start: a later call with the same ends
gets the order a fresh one would make, printed with its own paths' points and pitches."""

from __future__ import annotations

import numpy as np
from loadpath.splice import plan
from loadpath.splice.plan import order_paths


def _paths(rng, n=40, wiggle=0.0):
    out = []
    for k in range(n):
        y = 0.45 * k
        x = np.linspace(0.0, 20.0 + rng.uniform(-3, 3), 6)
        pts = np.column_stack([x, np.full(6, y)])
        pts[1:-1, 1] += wiggle  # interior vertices only: the ends stay
        out.append((pts, np.full(6, 0.45 + wiggle)))
    rng.shuffle(out)
    return out


def test_a_kept_order_is_the_fresh_one_with_the_new_paths_arrays():
    rng = np.random.default_rng(3)
    first = _paths(rng)
    again = [(p.copy(), w.copy()) for p, w in first]
    for p, w in again:  # the same ends, other interior points and pitches
        p[1:-1, 1] += 0.01
        w += 0.01
    start = np.array([-5.0, 3.0])
    plan._ORDERS.clear()
    a = order_paths(first, start, free_travel=1.0, retract_cost=2.0)
    assert len(plan._ORDERS) == 1
    b = order_paths(again, start, free_travel=1.0, retract_cost=2.0)
    assert len(plan._ORDERS) == 1  # served from the kept order
    plan._ORDERS.clear()
    fresh = order_paths(again, start, free_travel=1.0, retract_cost=2.0)
    assert len(b) == len(fresh) == len(first)
    for (pb, wb), (pf, wf) in zip(b, fresh, strict=True):
        assert np.array_equal(pb, pf) and np.array_equal(wb, wf)
    # the points printed are the second call's, in the first call's order
    ids_a = [int(round(q[0][0, 1] / 0.45)) for q in a]
    ids_b = [int(round(q[0][0, 1] / 0.45)) for q in b]
    assert ids_a == ids_b
    assert all(np.isclose(w[0], 0.46) for _, w in b)
    # another start is another order's key
    order_paths(again, np.array([30.0, 0.0]), free_travel=1.0, retract_cost=2.0)
    assert len(plan._ORDERS) == 2


def test_the_greedy_order_from_the_cost_table_is_the_step_by_step_one():
    """_greedy_from_table (issue 17) against _greedy, the step-by-step reference: the same order on
    random ends, on ends on a grid (ties between heads and tails, and between paths) and with the
    retraction's cost (steps in the costs)."""
    rng = np.random.default_rng(11)
    for trial in range(60):
        m = int(rng.integers(1, 90))
        if trial % 3 == 0:  # ties
            heads = rng.integers(0, 5, (m, 2)).astype(float)
            tails = rng.integers(0, 5, (m, 2)).astype(float)
        else:
            heads, tails = rng.uniform(0, 60, (m, 2)), rng.uniform(0, 60, (m, 2))
        start = rng.uniform(-5, 65, 2)
        for free, extra in ((0.0, 0.0), (1.0, 10.0), (3.0, 2.5)):
            cost = plan._travel_cost(free, extra)
            table = plan._cost_table(heads, tails, start, cost)
            assert plan._greedy_from_table(table, m) == plan._greedy(heads, tails, start, cost)
