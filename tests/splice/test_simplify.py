"""plan.simplify (all paths of a block in one numpy pass per level) against a plain per-path reference.

The splicer writes whatever vertices simplify keeps, so the vectorized version must keep exactly
the vertices of the straightforward recursive Ramer-Douglas-Peucker below, on every path; and so
must the compiled pass large splices load (:mod:`loadpath.splice.compiled`), down to the bytes
the splice writes on a real file (where the bead runs' compiled run index is used too).
"""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.splice import compiled
from loadpath.splice.plan import simplify, simplify_mask


@pytest.fixture(params=["numpy", "compiled"])
def rdp(request, monkeypatch):
    """The RDP pass simplify_mask runs: numpy's levels, or the compiled loop (unloaded after)."""
    monkeypatch.setattr(compiled, "_LOADED", {})
    if request.param == "compiled":
        compiled.load()
        assert compiled.kernel("rdp") is not None
    return request.param


def _errors(pts, pit, a, z, tol, pitch_tol):
    """Error of the vertices strictly between a and z against the chord a-z (position and pitch)."""
    d = pts[z] - pts[a]
    rel = pts[a + 1 : z] - pts[a]
    seg2 = d[0] * d[0] + d[1] * d[1]
    seg = np.sqrt(seg2)
    if seg > 0:
        dist = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) / seg
        t = np.clip((rel[:, 0] * d[0] + rel[:, 1] * d[1]) / seg2, 0, 1)
    else:
        dist = np.hypot(rel[:, 0], rel[:, 1])
        t = np.zeros(len(rel))
    interp = pit[a] + t * (pit[z] - pit[a])
    return np.maximum(dist / tol, np.abs(pit[a + 1 : z] - interp) / pitch_tol)


def reference(paths, tol, pitch_tol, min_segment):
    """One path at a time: recursive RDP (split at the first worst vertex), then the min_segment pass."""
    out = []
    for pts, pit in paths:
        n = len(pts)
        keep = np.zeros(n, dtype=bool)
        keep[0] = keep[-1] = True
        stack = [(0, n - 1)]
        while stack:
            a, z = stack.pop()
            if z - a < 2:
                continue
            err = _errors(pts, pit, a, z, tol, pitch_tol)
            k = int(np.nanargmax(err)) if not np.all(np.isnan(err)) else 0
            if err[k] > 1.0:
                keep[a + 1 + k] = True
                stack += [(a, a + 1 + k), (a + 1 + k, z)]
        ix = list(np.flatnonzero(keep))
        if len(ix) > 2 and min_segment > 0:
            gaps = [float(np.hypot(*(pts[j] - pts[i]))) for i, j in zip(ix[:-1], ix[1:], strict=True)]
            drop = {ix[k] for k in range(1, len(ix) - 1) if gaps[k - 1] < min_segment}
            if gaps[-1] < min_segment:
                drop.add(ix[-2])
            ix = [i for i in ix if i not in drop]
        out.append((pts[ix], pit[ix]))
    return out


def _random_paths(rng, n_paths):
    paths = []
    for _ in range(n_paths):
        n = int(rng.integers(1, 60))
        kind = rng.integers(4)
        if kind == 0:  # wobbly line: steps of 0.01-1 mm, sideways noise around the tolerance
            steps = np.stack([rng.uniform(0.01, 1.0, n), rng.normal(0, 0.01, n)], 1)
        elif kind == 1:  # random walk with repeated points (zero-length chords)
            steps = rng.normal(0, 0.3, (n, 2))
            steps[rng.random(n) < 0.2] = 0.0
        elif kind == 2:  # on a 0.005 mm grid: collinear vertices and exact ties
            steps = rng.integers(-3, 4, (n, 2)) * 0.005
        else:  # a closed loop (first point = last)
            ang = np.linspace(0, 2 * np.pi, n)
            steps = np.diff(np.stack([np.cos(ang), np.sin(ang)], 1) * rng.uniform(0.05, 5), axis=0, prepend=0)
        pts = np.cumsum(steps, axis=0) + rng.uniform(0, 200, 2)
        pitch = 0.45 + np.cumsum(rng.normal(0, 0.01, n))
        if rng.random() < 0.3:
            pitch = np.round(pitch, 2)  # steps of exactly the pitch tolerance
        paths.append((pts, pitch))
    return paths


@pytest.mark.parametrize("seed", range(4))
def test_simplify_equals_per_path_reference(seed, rdp):
    rng = np.random.default_rng(seed)
    paths = _random_paths(rng, 150)
    for tol, pitch_tol, min_segment in ((0.005, 0.025, 0.05), (0.03, 0.2, 0.0), (0.001, 0.01, 0.3)):
        got = simplify(paths, tol, pitch_tol, min_segment)
        want = reference(paths, tol, pitch_tol, min_segment)
        assert len(got) == len(want) == len(paths)
        for k, ((gp, gw), (wp, ww)) in enumerate(zip(got, want, strict=True)):
            assert np.array_equal(gp, wp), f"path {k}: kept vertices differ"
            assert np.array_equal(gw, ww), f"path {k}: kept pitches differ"
            assert np.array_equal(gp[[0, -1]], paths[k][0][[0, -1]])  # ends always kept


def test_simplify_drops_what_it_may(rdp):
    """A straight, evenly sampled line keeps its two ends; a corner keeps its corner."""
    x = np.linspace(0, 10, 101)
    line = (np.stack([x, 0.001 * np.sin(x)], 1), np.full(101, 0.45))
    corner = (np.array([[0, 0], [1, 0], [2, 0], [2, 1], [2, 2.0]]), np.full(5, 0.45))
    (lp, _), (cp, _) = simplify([line, corner], 0.005, 0.025, 0.05)
    assert np.array_equal(lp, line[0][[0, -1]])
    assert np.array_equal(cp, [[0, 0], [2, 0], [2, 2]])


def test_simplify_mask_on_ragged_arrays(rdp):
    rng = np.random.default_rng(42)
    paths = _random_paths(rng, 40)
    sizes = np.array([len(p) for p, _ in paths])
    pts = np.concatenate([p for p, _ in paths])
    keep = simplify_mask(pts, np.concatenate([w for _, w in paths]), sizes, 0.005, 0.025, 0.05)
    path_of = np.repeat(np.arange(len(paths)), sizes)
    for k, (wp, _) in enumerate(reference(paths, 0.005, 0.025, 0.05)):
        assert np.array_equal(pts[keep & (path_of == k)], wp)
    assert simplify([], 0.005) == []
    assert not simplify_mask(np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=int), 0.005).any()


def test_compiled_splice_writes_the_same_bytes(sliced, monkeypatch):
    """A real PrusaSlicer file spliced with the numpy pass and with the compiled one (loaded by the
    splice itself from COMPILED_FROM vertices): the same output, byte for byte."""
    from loadpath import gcode
    from splice_helpers import infill_blocks, rectilinear_fills, run_splice

    program = gcode.read(sliced("prusa", "ohs", "mixed"))
    fills = [_wavy(f) for f in rectilinear_fills(program, infill_blocks(program))]
    assert sum(len(p.points) for f in fills for p in f.paths) > 20_000
    monkeypatch.setattr(compiled, "_LOADED", {})
    numpy_out = run_splice(program, fills)[0].data
    assert compiled.kernel("rdp") is None  # a small file: numpy's pass
    monkeypatch.setattr(compiled, "COMPILED_FROM", 1)
    compiled_out = run_splice(program, fills)[0].data
    assert compiled.kernel("rdp") is not None and compiled.kernel("runs") is not None
    assert compiled_out == numpy_out


def _wavy(fill):
    """The fill's straight lines as curves: a vertex every 0.1 mm, 0.03 mm to either side and back
    over 2 mm, the pitch varying by 0.02 mm (so the RDP pass has vertices to weigh)."""
    import dataclasses

    from loadpath.toolpath import Path

    out = []
    for p in fill.paths:
        seg = np.hypot(*np.diff(p.points, axis=0).T)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        at = np.linspace(0.0, s[-1], max(2, int(s[-1] / 0.1) + 1))
        pts = np.stack([np.interp(at, s, p.points[:, k]) for k in (0, 1)], 1)
        d = p.points[-1] - p.points[0]
        normal = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
        pts = pts + 0.03 * np.sin(at * np.pi)[:, None] * normal
        pitch = np.interp(at, s, p.pitch) + 0.02 * np.sin(at * 0.7)
        out.append(Path(pts, pitch, p.kind))
    return dataclasses.replace(fill, paths=tuple(out))
