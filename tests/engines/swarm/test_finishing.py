"""The swarm engine's finishing steps on hand-made layers: centring, squeezed ends, gap beads."""

from __future__ import annotations

import numpy as np
import shapely
from loadpath import metrics as M
from loadpath.engines.finish.ends import extend_ends
from loadpath.engines.swarm.gaps import gap_fill
from loadpath.engines.finish.widths import centre_points, local_pitch
from loadpath.toolpath import Path
from shapely.geometry import box

PITCH = 0.4


def _line(y0, y1=None, x0=0.0, x1=10.0, n=26):
    x = np.linspace(x0, x1, n)
    y = np.linspace(y0, y0 if y1 is None else y1, n)
    return np.column_stack([x, y])


def test_uneven_neighbours_centre_the_middle_path_between_mid_gaps():
    # neighbours 0.6 pitch below and 1.4 pitch above: a bead of the mean width (1 pitch) centred on
    # the middle path covers 0.2 pitch of the lower bead; moved up by (L - R) / 4 it tiles both gaps
    region = box(0, -2, 10, 2)
    paths = [_line(-0.6 * PITCH), _line(0.0), _line(1.4 * PITCH)]
    only = [np.zeros(26, bool), np.ones(26, bool), np.zeros(26, bool)]
    w, left, right = local_pitch(paths, region, PITCH, only=only, sides=True)
    assert np.allclose(w[1][1:-1], PITCH)
    moved = centre_points(paths, left, right, 0.25 * PITCH, 0.53 * PITCH)
    assert np.allclose(moved[1][:, 1], 0.2 * PITCH)  # (1.4 - 0.6) / 4 pitches up
    assert np.allclose(moved[0], paths[0]) and np.allclose(moved[2], paths[2])
    # its bead's edges now lie on the mid-gaps (-0.3 and +0.7 pitch): neither neighbour is covered
    y, half = moved[1][1:-1, 1], 0.5 * w[1][1:-1]
    assert np.allclose(y - half, -0.3 * PITCH) and np.allclose(y + half, 0.7 * PITCH)


def test_centring_never_brings_paths_closer_than_the_gap():
    # two paths that the rays see as far apart on one side but that converge: no move may end up
    # closer than min_gap, whatever the measured sides say
    region = box(-1, -2, 11, 2)
    paths = [_line(-0.6 * PITCH), _line(0.0, 0.9 * PITCH), _line(1.5 * PITCH, 1.1 * PITCH)]
    _, left, right = local_pitch(paths, region, PITCH, sides=True)
    moved = centre_points(paths, left, right, 0.5 * PITCH, 0.53 * PITCH)
    sp = M.spacing([Path(p, np.full(len(p), PITCH)) for p in moved], PITCH)
    assert sp.min >= 0.53 - 0.02
    assert not np.allclose(moved[1], paths[1])  # something did move


def test_a_squeezed_end_does_not_run_on_along_its_neighbours():
    # the middle path ends between two neighbours 0.75 pitch away on either side: with overlap = 0
    # it is not extended (its bead would cover both), with the centre-line test alone it runs on
    region = box(-1, -2, 12, 2)
    paths = [_line(-0.75 * PITCH), _line(0.0, x1=5.0, n=13), _line(0.75 * PITCH)]
    widths = [np.full(len(p), PITCH) for p in paths]
    p0, _, _ = extend_ends(paths, widths, region, PITCH, overlap=0.0, edge_gap=0.0)
    p1, _, _ = extend_ends(paths, widths, region, PITCH, overlap=None, edge_gap=0.0)
    assert p0[1][-1, 0] == 5.0  # the squeezed end stays
    assert p1[1][-1, 0] > 5.0 + 2.0 * PITCH  # the centre-line test lets it run on


def test_gap_bead_in_the_void_where_two_fronts_meet_head_on():
    # two sets of parallel paths meeting head on with a 1.4 pitch void between their ends
    region = box(0, 0, 10, 4)
    ys = PITCH * (0.5 + np.arange(10))
    paths = [_line(y, x0=0.2, x1=4.5, n=12) for y in ys] + [_line(y, x0=5.06, x1=9.8, n=12) for y in ys]
    widths = [np.full(len(p), PITCH) for p in paths]
    gp, gw, st = gap_fill(paths, widths, region, PITCH)
    assert st["gap_beads"] >= 1
    tp_before = [Path(p, w) for p, w in zip(paths, widths, strict=True)]
    tp_after = tp_before + [Path(p, w, kind="fill") for p, w in zip(gp, gw, strict=True)]
    seam = box(4.3, 0, 5.3, 4)
    cov0 = shapely.intersection(
        shapely.union_all(
            [shapely.buffer(shapely.LineString(p.points), 0.5 * PITCH, cap_style="flat") for p in tp_before]
        ),
        seam,
    ).area
    cov1 = shapely.intersection(
        shapely.union_all(
            [
                shapely.buffer(shapely.LineString(p.points), 0.5 * p.pitch[0], cap_style="flat")
                for p in tp_after
            ]
        ),
        seam,
    ).area
    assert cov1 > cov0 + 0.5 * PITCH * 3.0  # most of the seam's void is filled
    # the beads run along the seam (its long axis), keep the half-pitch rule and do not cross
    for q in gp:
        d = q[1] - q[0]
        assert abs(d[0]) < 0.2 * abs(d[1])
    assert M.crossings(tp_after) == 0
    assert M.spacing(tp_after, PITCH).min >= 0.5


def test_phase_half_lays_paths_between_those_of_phase_zero():
    # a strip pulled along x: the staggered layer's paths run between the first layer's
    from loadpath.engines.swarm import generate
    from loadpath.field import AnalyticField
    from loadpath.toolpath import EngineInput
    from shapely.geometry import LineString

    region = box(0, 0, 20, 6)
    field = AnalyticField(lambda p: np.tile([1.0, 0.0, 0.0], (len(p), 1)), region, scale=1.0)
    inp = EngineInput(region=region, field=field, pitch=PITCH, load_entry=LineString([(20, 0), (20, 6)]))
    ys = [
        np.sort(
            [np.median(p.points[:, 1]) for p in generate(inp, K=5.0, phase=ph).paths if len(p.points) > 20]
        )
        for ph in (0.0, 0.5)
    ]
    a, b = ys
    inner = b[(b > a[0]) & (b < a[-1])]
    assert len(inner) >= len(a) - 2
    # the staggered paths sit between those of phase 0: half a pitch off in the middle, less toward
    # the long sides, where the boundary agents hold the outermost paths at the same distance
    off = np.min(np.abs(inner[:, None] - a[None, :]), axis=1)
    assert np.median(off) > 0.4 * PITCH and off.min() > 0.2 * PITCH, off / PITCH
