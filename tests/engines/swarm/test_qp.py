"""The swarm's QP layer: the exact banded solver against OSQP, the chain QP against Eq. 3-12."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.engines.swarm import qp as Q
from loadpath.engines.swarm.banded import BandedQP, banded_to_dense, solve_banded_box_qp
from loadpath.engines.swarm.chain import ChainProblem, build_qp, potentials
from loadpath.errors import SolverError


def _random_banded(n: int, rng: np.random.Generator) -> BandedQP:
    u = 3
    h = np.zeros((n, n))
    for i in range(n):  # sum of local rank-one terms: a banded PSD matrix like the chain's
        v = rng.normal(size=min(u + 1, n - i))
        h[i : i + len(v), i : i + len(v)] += np.outer(v, v)
    h += np.eye(n) * rng.uniform(0.01, 1.0)
    ab = np.zeros((u + 1, n))
    for k in range(min(u, n - 1) + 1):
        ab[u - k, k:] = np.diag(h, k)
    lo = -rng.uniform(0.0, 0.5, n)
    hi = rng.uniform(0.0, 0.5, n)
    pinned = rng.random(n) < 0.1
    hi[pinned] = lo[pinned]
    return BandedQP(ab, rng.normal(size=n) * 3.0, lo, hi)


def test_banded_solver_matches_osqp_on_random_instances():
    rng = np.random.default_rng(12345)
    for _ in range(150):
        qp = _random_banded(int(rng.integers(1, 160)), rng)
        exact = solve_banded_box_qp(qp)
        ref = Q.solve_osqp(qp)
        assert exact.converged and exact.kkt <= 1e-10
        assert ref.status == "osqp:solved"
        assert np.all(exact.x >= qp.lo) and np.all(exact.x <= qp.hi)
        assert np.max(np.abs(exact.x - ref.x)) < 1e-6
        assert exact.objective <= ref.objective + 1e-9 * (1 + abs(ref.objective))


def test_banded_solver_warm_start_and_unconstrained_optimum():
    rng = np.random.default_rng(7)
    qp = _random_banded(40, rng)
    wide = BandedQP(qp.ab, qp.q, np.full(40, -1e6), np.full(40, 1e6))
    x = solve_banded_box_qp(wide).x
    assert np.allclose(banded_to_dense(qp.ab) @ x, -qp.q, atol=1e-8)  # H x = -q
    cold = solve_banded_box_qp(qp)
    warm = solve_banded_box_qp(qp, x0=cold.x)
    assert warm.iterations == 0 and np.allclose(warm.x, cold.x)


def test_solve_reports_status_and_rejects_bad_data():
    rng = np.random.default_rng(3)
    qp = _random_banded(10, rng)
    assert Q.solve(qp).status == "exact"
    bad = BandedQP(qp.ab, np.full(10, np.nan), qp.lo, qp.hi)
    with pytest.raises(SolverError, match="non-finite"):
        Q.solve(bad)
    infeasible = BandedQP(qp.ab, qp.q, np.ones(10), np.zeros(10))  # lo > hi
    with pytest.raises(SolverError, match="OSQP (returned status|rejected)"):
        Q.solve_osqp(infeasible)


def test_solve_falls_back_to_osqp_when_the_exact_solver_gives_up(monkeypatch):
    rng = np.random.default_rng(4)
    qp = _random_banded(12, rng)
    real = Q.solve_banded_box_qp
    monkeypatch.setattr(Q, "solve_banded_box_qp", lambda p, x0=None, tol=0: real(p, x0, tol, max_iter=0))
    sol = Q.solve(qp)
    assert sol.status == "osqp:solved" and sol.kkt < 1e-5


def test_chain_qp_equals_the_swarm_potential():
    rng = np.random.default_rng(1)
    n = 7
    ang = rng.uniform(0, 2 * np.pi, n)
    e1 = np.stack([np.cos(ang), np.sin(ang)], 1)
    frame = np.stack([e1, np.stack([-e1[:, 1], e1[:, 0]], 1)], 1)
    radial = rng.normal(size=(n - 1, 2))
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    cp = ChainProblem(
        t=rng.normal(size=(n, 2)),
        frame=frame,
        lo=-np.ones((n, 2)),
        hi=np.ones((n, 2)),
        weight=rng.uniform(0, 2, n),
        link=np.array([1, 1, 0, 1, 1, 1], bool),
        radial=radial,
        target=rng.uniform(0.5, 1.0, n - 1),
    )
    qp, c0 = build_qp(cp)
    h = banded_to_dense(qp.ab)
    for _ in range(5):
        u = rng.normal(size=2 * n)
        uu = u.reshape(-1, 2)
        x = cp.t + np.einsum("ja,jak->jk", uu, frame)
        v = x[1:] - x[:-1]
        # Eq. 7-9 written out: (v.d - L)^2 + |v - (v.d) d|^2, and Eq. 3 squared: K m |x - t|^2
        vd = np.sum(v * radial, axis=1)
        pa = (vd - cp.target) ** 2 + np.sum((v - vd[:, None] * radial) ** 2, axis=1)
        pe = cp.weight * np.sum((x - cp.t) ** 2, axis=1)
        p_direct = np.sum(pa[cp.link]) + np.sum(pe)
        assert 0.5 * u @ h @ u + qp.q @ u + c0 == pytest.approx(p_direct, rel=1e-12)
        pair, agent = potentials(cp, u)
        assert np.sum(pair) + np.sum(agent) == pytest.approx(p_direct, rel=1e-12)
