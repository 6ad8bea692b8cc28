"""Bead runs: fewer vertices and width markers, same material per path, bounded deviation."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from loadpath.splice.beadruns import RunOptions, bead_runs, runs_of_widths, smooth_filament
from loadpath.splice.flow import FlowModel
from loadpath.splice.plan import PlanOptions, plan_block
from loadpath.toolpath import Path
from shapely.geometry import LineString

FLOW = FlowModel("rounded", 1.75)
H = 0.2
PITCH = 0.41


def _paths(n=24, length=60.0, seed=0):
    """Gently curved lines 0.41 mm apart with a slow wobble, a width ramp and per-vertex pitch noise
    (what the engines give: a local pitch jumping by ~20 % between vertices 0.4 mm apart)."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, length, 400)
    out = []
    for k in range(n):
        y = k * PITCH + 0.6 * np.sin(x / 15.0) + 0.03 * np.sin(x / 3.1 + k)
        pitch = PITCH * (1 + 0.25 * np.exp(-(((x - 30) / 5) ** 2))) * (1 + 0.1 * rng.standard_normal(len(x)))
        pts = np.c_[x, y]
        out.append(Path(pts if k % 2 == 0 else pts[::-1], pitch if k % 2 == 0 else pitch[::-1]))
    return out


def _plan(paths):
    region = shapely.box(-1.0, -1.5, 61.0, 24 * PITCH + 1.0)
    opts = PlanOptions(nozzle_diameter=0.4, match_volume=False)
    return plan_block(paths, np.zeros(2), H, 2400.0, FLOW, opts, region=region, nominal_pitch=PITCH)


def _per_path_filament(chain, ends):
    """Filament of each stretch between path ends along a chain (paths and links)."""
    cut = np.isin(chain.points @ np.array([1.0, 1j]), ends @ np.array([1.0, 1j]))
    cut[0] = cut[-1] = True
    group = np.cumsum(cut[:-1]) - 1
    return np.bincount(group, weights=chain.filament)


@pytest.mark.parametrize("corridor, refit", [(False, False), (False, True), (True, False)])
def test_runs_keep_every_paths_material_and_stay_close(corridor, refit):
    paths = _paths()
    plan = _plan(paths)
    ends = np.array([p.points[i] for p in paths for i in (0, -1)])
    opts = RunOptions(corridor=corridor, refit=refit)
    out = bead_runs(plan, FLOW, H, PITCH, PlanOptions().resolution, ends, opts)
    assert len(out.chains) == len(plan.chains) and plan.n_links > 0
    for c0, c1 in zip(plan.chains, out.chains, strict=True):
        # every path (and link) extrudes exactly what the plan gave it
        np.testing.assert_allclose(_per_path_filament(c1, ends), _per_path_filament(c0, ends), rtol=1e-9)
        # the printed line is within resolution * flow width of the planned one (minus the first pass)
        dev = shapely.hausdorff_distance(LineString(c0.points), LineString(c1.points))
        assert dev <= opts.resolution * PITCH - PlanOptions().resolution + 1e-9
        # never faster than the plan anywhere (the volumetric limit holds)
        assert c1.feedrate.max() <= c0.feedrate.max()
    n0 = sum(len(c.width) for c in plan.chains)
    n1 = sum(len(c.width) for c in out.chains)
    markers0 = sum(int(np.sum(np.abs(np.diff(np.round(c.width, 2))) >= 0.02)) + 1 for c in plan.chains)
    markers1 = sum(int(np.sum(np.diff(c.width) != 0)) + 1 for c in out.chains)
    assert n1 < 0.5 * n0
    assert markers1 < 0.25 * markers0 and markers1 == out.stats["runs"]
    # the width ramp in the middle is still printed (wider beads where the pitch is wider)
    c = out.chains[0]
    mid = np.abs(0.5 * (c.points[:-1, 0] + c.points[1:, 0]) - 30) < 3
    far = np.abs(0.5 * (c.points[:-1, 0] + c.points[1:, 0]) - 30) > 20
    assert c.width[mid].mean() > 1.1 * c.width[far].mean()


def test_refit_drops_vertices_the_runs_do_not_need():
    """The second pass (runs' first vertices fixed, position only) keeps fewer vertices, within the
    same bound, each path's filament exact, and each run still printed at one width per marker."""
    paths = _paths(seed=2)
    plan = _plan(paths)
    ends = np.array([p.points[i] for p in paths for i in (0, -1)])
    done = PlanOptions().resolution
    once = bead_runs(plan, FLOW, H, PITCH, done, ends, RunOptions(refit=False))
    twice = bead_runs(plan, FLOW, H, PITCH, done, ends, RunOptions(refit=True))
    n1 = sum(len(c.points) for c in once.chains)
    n2 = sum(len(c.points) for c in twice.chains)
    assert n2 < n1
    assert twice.stats["runs"] <= 1.1 * once.stats["runs"]
    for c0, c2 in zip(plan.chains, twice.chains, strict=True):
        np.testing.assert_allclose(_per_path_filament(c2, ends), _per_path_filament(c0, ends), rtol=1e-9)
        dev = shapely.hausdorff_distance(LineString(c0.points), LineString(c2.points))
        assert dev <= RunOptions().resolution * PITCH - done + 1e-9


def test_markers_say_the_width_printed_on_long_segments():
    paths = _paths(seed=1)
    plan = _plan(paths)
    ends = np.array([p.points[i] for p in paths for i in (0, -1)])
    opts = RunOptions()
    out = bead_runs(plan, FLOW, H, PITCH, PlanOptions().resolution, ends, opts)
    for c in out.chains:
        seg = np.hypot(*np.diff(c.points, axis=0).T)
        printed = FLOW.bead_width(c.filament / seg * FLOW.filament_area / H, H)
        long = seg > opts.short * PITCH
        assert np.all(np.abs(printed[long] - c.width[long]) <= opts.width_step * c.width[long] + 1e-9)


@pytest.fixture(params=["python", "compiled"])
def runs_pass(request, monkeypatch):
    """The pass runs_of_widths makes: its Python loop, or the compiled one (unloaded after)."""
    from loadpath.splice import compiled

    monkeypatch.setattr(compiled, "_LOADED", {})
    if request.param == "compiled":
        compiled.load()
    return request.param


def test_runs_of_widths_band_and_short_segments(runs_pass):
    w = np.array([0.45, 0.46, 0.47, 0.60, 0.46, 0.45, 0.52, 0.53])
    ln = np.array([2.0, 2.0, 2.0, 0.3, 2.0, 2.0, 2.0, 2.0])
    run = runs_of_widths(w, ln, 0.05, 0.8)
    assert run.tolist() == [0, 0, 0, 0, 0, 0, 1, 1]  # 0.60 is a short link: absorbed
    assert runs_of_widths(w, ln, 0.0, 0.0).tolist() == [0, 1, 2, 3, 4, 5, 6, 7]
    start = np.array([False, False, False, False, True, False, False, False])
    assert runs_of_widths(w, ln, 0.05, 0.8, start).tolist() == [0, 0, 0, 0, 1, 1, 2, 2]


def test_compiled_runs_equal_the_python_loop(monkeypatch):
    """Random widths on a 0.01 mm grid (exact ties at the band's edge), short segments, chain starts
    (also on a short segment, and first): the compiled pass gives the loop's runs."""
    from loadpath.splice import compiled

    rng = np.random.default_rng(11)
    monkeypatch.setattr(compiled, "_LOADED", {})
    cases = []
    for _ in range(200):
        n = int(rng.integers(1, 80))
        w = np.round(rng.uniform(0.40, 0.60, n), 2)
        ln = rng.uniform(0.0, 3.0, n)
        start = rng.random(n) < 0.1
        step = float(rng.choice([0.0, 0.05, 0.15, 0.25]))
        cases.append((w, ln, step, 0.8, start if rng.random() < 0.8 else None))
    want = [runs_of_widths(*c) for c in cases]
    compiled.load()
    for c, w in zip(cases, want, strict=True):
        assert runs_of_widths(*c).tolist() == w.tolist()


@pytest.mark.parametrize("window", [0.0, 1.0, 5.0, 100.0])
def test_smoothing_keeps_each_groups_material(window):
    rng = np.random.default_rng(3)
    ln = rng.uniform(0.1, 2.0, 50)
    fil = ln * rng.uniform(0.02, 0.05, 50)
    group = np.repeat([0, 1, 2], [20, 5, 25])
    out = smooth_filament(fil, ln, window, group)
    np.testing.assert_allclose(np.bincount(group, weights=out), np.bincount(group, weights=fil), rtol=1e-12)
    dens = out / ln
    if window >= 100:  # the whole group at its mean
        np.testing.assert_allclose(dens[:20], fil[:20].sum() / ln[:20].sum(), rtol=1e-9)
