"""travel.prepare_wipes (every chain's wipe of a block in one numpy pass) against wipe_back alone.

The spliced file must stay byte-identical to what the per-chain wipe wrote (issue 17): the same
lines, and the writer left in the same state (E, rounding carry, retraction, time, position), for
chains long and short, tails shorter than the wipe, repeated points and both E modes.
"""

from __future__ import annotations

import numpy as np
import pytest
from loadpath.splice.emit import STYLES, Writer
from loadpath.splice.travel import Motion, TravelState, prepare_wipes, wipe_back, wipe_distance


def _chains(rng: np.random.Generator) -> list[np.ndarray]:
    out = []
    for n in [2, 3, 5, 8, 16, 17, 18, 40, 300, 2, 9, 4]:
        steps = rng.uniform(-1.5, 1.5, (n - 1, 2)) * rng.choice([0.01, 0.3, 1.0, 4.0])
        pts = np.cumsum(np.vstack([rng.uniform(20, 200, (1, 2)), steps]), axis=0)
        if n > 4:
            pts[-2] = pts[-3]  # a segment of zero length near the end
        out.append(pts)
    out.append(np.array([[10.0, 10.0], [10.0, 10.0005], [10.0, 10.001]]))  # a tail far shorter than a wipe
    out.append(np.array([[10.0, 10.0], [13.0, 14.0]]))
    return out


def _state(w: Writer) -> tuple:
    return (w.lines, w.e, w._e_exact, w._carry, w.retracted, w.seconds, w.x, w.y)


@pytest.mark.parametrize("relative", [True, False])
@pytest.mark.parametrize("family", ["prusa", "cura"])
@pytest.mark.parametrize("distance", [0.5, 3.29, 40.0])
def test_prepared_wipes_write_what_wipe_back_writes(relative, family, distance):
    rng = np.random.default_rng(int(distance * 100) + relative)
    chains = _chains(rng)
    style = STYLES[family]
    st = TravelState(None, None, Motion(), 0.2)
    prepare_wipes(st, chains, distance, style.leading_zero)
    assert st.wipes  # most chains take the prepared wipe
    for c in chains:
        for total in (0.76, 0.0123456):
            made = []
            for tail in (None, st.wipes.get(id(c))):
                w = Writer(style, float(c[-1, 0]), float(c[-1, 1]), 0.2, 3.1, 8640.0, relative)
                w._carry = 3.3e-6
                pulled = wipe_back(w, c, distance, total, tail)
                made.append((pulled, _state(w)))
            assert made[0] == made[1]


def test_a_prepared_wipe_is_not_used_away_from_its_chain_end():
    chains = _chains(np.random.default_rng(5))
    st = TravelState(None, None, Motion(), 0.2)
    prepare_wipes(st, chains, 3.0)
    c = chains[6]
    w1, w2 = (Writer(STYLES["prusa"], 1.0, 2.0, 0.2, 0.0, 8640.0, True) for _ in range(2))
    wipe_back(w1, c, 3.0, 0.76)
    wipe_back(w2, c, 3.0, 0.76, st.wipes[id(c)])
    assert _state(w1) == _state(w2)


def test_wipe_distance_is_the_retractions():
    m = Motion()
    r = m.retraction
    assert wipe_distance(m) == r.length / r.speed * (0.8 * m.travel_speed)
