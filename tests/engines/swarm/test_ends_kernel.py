"""The compiled first-blocked search of the path-end extensions against a brute-force reference."""

import numpy as np
import pytest
from loadpath.engines.finish.ends import _first_blocked


def _reference(arrays, r_max, clear, cap, overlap, own_far):
    """Every (candidate, sample) pair in plain numpy, then the first failing candidate per end.

    ``arrays`` are :func:`_first_blocked`'s array arguments, in its order.
    """
    cand, ok, s, end_pt, end_dir, end_w, end_pid, end_arc, dp, did, dw, darc = arrays
    n_e, n_s = ok.shape
    c = cand.reshape(-1, 2)
    e_of = np.repeat(np.arange(n_e), n_s)
    j_of = np.tile(np.arange(n_s), n_e)
    d = np.hypot(*(c[:, None, :] - dp[None, :, :]).transpose(2, 0, 1))  # (e n_s, m)
    near = d <= r_max
    own = (did[None, :] == end_pid[e_of, None]) & (np.abs(darc[None, :] - end_arc[e_of, None]) <= own_far)
    ahead_bad = d < np.maximum(clear, 0.5 * dw[None, :] + cap * end_w[e_of, None])
    if np.isnan(overlap):
        bad = ahead_bad
    else:
        rel = dp[None, :, :] - end_pt[e_of, None, :]
        u = np.sum(rel * end_dir[e_of, None, :], axis=2)
        v = np.abs(rel[..., 0] * end_dir[e_of, None, 1] - rel[..., 1] * end_dir[e_of, None, 0])
        sc = s[j_of, None]
        dx = np.maximum(np.maximum(u - sc, -u), 0.0)
        dy = np.maximum(v - 0.5 * end_w[e_of, None], 0.0)
        lateral = ((dx == 0) & (dy == 0)) | (
            np.hypot(dx, dy) < 0.5 * dw[None, :] - overlap * end_w[e_of, None]
        )
        bad = np.where(u > sc, ahead_bad, lateral | (d < clear))
    blocked = np.any(bad & near & ~own, axis=1).reshape(n_e, n_s)
    good = ok & ~blocked
    return np.where(good.all(axis=1), n_s, np.argmin(good, axis=1))


@pytest.mark.parametrize("overlap", [np.nan, 0.0, 0.25])
def test_first_blocked_matches_every_pair_checked(overlap):
    rng = np.random.default_rng(3)
    pitch, n_s = 0.4, 12
    s = pitch / 9 * np.arange(1, n_s + 1)
    seen = []
    for trial in range(20):
        n_e, m = int(rng.integers(1, 30)), int(rng.integers(0, 400))
        end_pt = rng.uniform(0, 6, (n_e, 2))
        ang = rng.uniform(0, 2 * np.pi, n_e)
        end_dir = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        end_w = rng.uniform(0.2, 0.6, n_e)
        end_pid = rng.integers(0, 5, n_e)
        end_arc = rng.uniform(0, 10, n_e)
        cand = end_pt[:, None, :] + s[None, :, None] * end_dir[:, None, :]
        ok = rng.random((n_e, n_s)) > 0.05
        dp = rng.uniform(-0.5, 6.5, (m, 2))
        did = rng.integers(0, 5, m)
        dw = rng.uniform(0.2, 0.6, m)
        darc = rng.uniform(0, 10, m)
        clear, cap, own_far = 0.5 * pitch, 0.25, 1.6
        r_max = max(clear, 0.3 + 0.5 * 0.6) + s[0]
        args = (cand, ok, s, end_pt, end_dir, end_w, end_pid, end_arc, dp, did, dw, darc)
        # the kernel through the engine's own call (its grid of the samples and candidates)
        got = _first_blocked(*args, r_max, clear, cap, None if np.isnan(overlap) else overlap, own_far)
        want = _reference(args, r_max, clear, cap, overlap, own_far)
        assert np.array_equal(got, want), trial
        seen.append(got)
    # the instances exercise every outcome: blocked at once, part way, and free throughout
    seen = np.concatenate(seen)
    assert np.any(seen == 0) and np.any((seen > 0) & (seen < n_s)) and np.any(seen == n_s)
