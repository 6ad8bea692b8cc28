"""emit.width_changes (every chain's width markers of a block in one numpy pass) against the markers
written chain by chain, and Writer.extrude_many with and without them: the same lines and state."""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.splice.emit import STYLES, Writer, _width_marks, width_changes


def _marks_one_chain(widths, current, step, hysteresis):
    """The markers of one chain as extrude_many wrote them before issue 17's pass: every segment
    tested in turn against the width stated last."""
    out = []
    for k, w in enumerate((np.round(np.asarray(widths) / step) * step).tolist()):
        if not abs(w - current) < hysteresis:
            current = w
            out.append((k, current))
    return out


@pytest.mark.parametrize(("step", "hysteresis"), [(0.001, 0.0005), (0.01, 0.0199), (0.01, 0.0)])
def test_width_changes_of_many_chains_give_each_chains_markers(step, hysteresis):
    rng = np.random.default_rng(7)
    sizes = [1, 2, 5, 40, 1, 300, 3]
    total = sum(sizes)
    widths = rng.uniform(0.3, 0.8, total)[np.arange(total) // 3]  # runs of three equal widths
    widths[20:26] = 0.4504  # rounds to the same as its neighbour below
    widths[26] = 0.4506
    widths[10] = np.nan
    got = width_changes(widths, sizes, step, hysteresis)
    at = np.cumsum([0, *sizes]).tolist()
    for current in (float("nan"), 0.45):
        for (a, z), ch in zip(zip(at[:-1], at[1:], strict=True), got, strict=True):
            got_marks = _width_marks(*ch, current, hysteresis)
            assert repr(got_marks) == repr(_marks_one_chain(widths[a:z], current, step, hysteresis))  # NaN too


@pytest.mark.parametrize("family", ["prusa", "cura"])
def test_extrude_many_with_the_blocks_changes_and_time_writes_the_same(family):
    rng = np.random.default_rng(9)
    chains = []
    for n in (3, 1, 25, 7):
        pts = np.cumsum(rng.uniform(-2, 2, (n + 1, 2)), axis=0) + 100.0
        chains.append((pts, rng.uniform(0.01, 0.2, n), np.full(n, 4800.0), np.round(rng.uniform(0.4, 0.5, n), 2)))
    changes = width_changes(np.concatenate([c[3] for c in chains]), [len(c[1]) for c in chains], 0.001, 0.0005)
    writers = [Writer(STYLES[family], 100.0, 100.0, 0.2, 0.0, 1800.0, True) for _ in range(2)]
    for (pts, de, f, wd), ch in zip(chains, changes, strict=True):
        seg = np.hypot(*(pts[1:] - pts[:-1]).T)
        writers[0].extrude_many(pts, de, f, wd, 0.001, 0.0005, seg=seg)
        secs = float(np.sum(seg / np.maximum(f, 1e-9)) * 60.0)
        writers[1].extrude_many(pts, de, f, wd, 0.001, 0.0005, seg=seg, changes=ch, seconds=secs)
    a, b = writers
    assert a.lines == b.lines and (a.seconds, a.width, a.e, a._carry) == (b.seconds, b.width, b.e, b._carry)
