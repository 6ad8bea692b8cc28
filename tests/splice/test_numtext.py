"""numtext (numbers formatted from numpy) against emit.fmt_many, the one-float-at-a-time reference.

The spliced file must be byte-identical to what the per-value formatting wrote, so every digit,
sign, point and dropped zero must match, near halves of the last digit most of all.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from loadpath.splice.emit import STYLES, _move_lines, _move_lines_plain, fmt_many
from loadpath.splice.numtext import lines, number_column, text_column, writable


def _values() -> list[np.ndarray]:
    rng = np.random.default_rng(17)
    n = 20_000
    return [
        rng.uniform(-300, 300, n),
        rng.uniform(-1, 1, n),
        np.round(rng.uniform(-300, 300, n), 3) + 0.0005,  # halves of the third decimal
        np.round(rng.uniform(-5, 5, n), 5) + 5e-6,  # and of the fifth
        rng.uniform(0, 20_000, n),
        np.array([0.0, -0.0, 1e-9, -1e-9, 0.0005, -0.0005, 0.0015, 2.5e-6, -2.5e-6, 1e6, 123456.9999996]),
        np.array([0.1, 0.7, 1.0005, 2.0005, 4800.0, 10800.0, 9.99e8, -9.99e8]),
    ]


@pytest.mark.parametrize("decimals", [3, 5, 6])
@pytest.mark.parametrize("leading_zero", [False, True])
def test_number_column_is_fmt(decimals, leading_zero):
    for v in _values():
        assert lines([number_column(v, decimals, leading_zero)]) == fmt_many(v, decimals, leading_zero)


def test_lines_join_columns_and_masks():
    n = 3
    keep = np.array([True, False, True])
    e = number_column([0.5, 0.25, -0.125], 5)
    e.keep &= keep[:, None]
    cols = [text_column("G1 X", n), number_column([1.0, 2.5, 0.0004], 3), text_column(" E", n, keep), e]
    assert lines(cols) == ["G1 X1 E.5", "G1 X2.5", "G1 X0 E-.125"]
    assert lines([text_column("G1", 0)]) == []


@pytest.mark.parametrize("family", ["prusa", "cura", "f-last"])
def test_move_lines_as_one_at_a_time(family):
    """A block's moves from numpy read as the per-value formatting wrote them, F words included."""
    style = STYLES.get(family) or dataclasses.replace(STYLES["prusa"], feed_line=False)
    rng = np.random.default_rng(3)
    n = 5000
    to = np.round(rng.uniform(0, 250, (n, 2)), 4)
    relative = np.round(rng.uniform(-1, 3, n), 6)
    e_vals = np.where(rng.random(n) < 0.5, relative, np.cumsum(rng.uniform(0, 0.05, n)))
    has_e = rng.random(n) < 0.9
    f = np.repeat(rng.choice([1200.0, 1500.5, 1800.0, 2700.125], n // 50), 50)
    change = np.flatnonzero(np.diff(np.concatenate([[-1.0], f])) != 0)
    assert _move_lines(style, to, e_vals, has_e, f, change) == _move_lines_plain(
        style, to, e_vals, has_e, f, change
    )
    to[7] = (np.nan, 1e300)  # what numpy cannot write: every line from the reference
    got = _move_lines(style, to, e_vals, has_e, f, change)
    assert got == _move_lines_plain(style, to, e_vals, has_e, f, change) and "nan" in got[7]


def test_number_column_refuses_what_it_cannot_write():
    assert not writable([1.0, np.nan], 3) and not writable([1e13], 3) and writable([-1e11], 3)
    with pytest.raises(ValueError):
        number_column([np.inf], 3)
