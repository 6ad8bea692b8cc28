"""Print order: greedy nearest endpoint (thesis Sec. 4.1.3, Fig. 4.6, App. C).

Start with filament 1 from its first end; after printing a filament, go to the nearest end of any
unprinted filament, which is printed from that end (reversed when it is the far end).  The thesis's
retraction rule (retract when the hop is longer than ``tol``; App. C's ``d_min <= tol`` is a typo,
digest §1.6) and its extruded short hops are the splicer's business: the engine returns separate
paths in print order, and never joins two filaments with an extruded connector, which could cross
or overlap other paths.  Nearest ends come from a ``cKDTree`` over all ends, asked for more
neighbours only when the nearest ones are already printed.
"""

from __future__ import annotations

import numpy as np
from loadpath._typing import Points2
from scipy.spatial import cKDTree

__all__ = ["link"]


def link(lines: list[Points2]) -> list[tuple[int, bool]]:
    """Greedy nearest-endpoint print order.

    Parameters
    ----------
    lines : list of (n_i, 2) arrays

    Returns
    -------
    list of (index, reversed)
        Every line once, in print order; ``reversed`` means print it from its last vertex.
    """
    m = len(lines)
    if m == 0:
        return []
    ends = np.array([[ln[0], ln[-1]] for ln in lines]).reshape(-1, 2)  # 2j: start, 2j+1: end
    tree = cKDTree(ends)
    done = np.zeros(m, dtype=bool)
    order = [(0, False)]
    done[0] = True
    here = lines[0][-1]
    for _ in range(m - 1):
        k = 8
        nxt = -1
        while nxt < 0:
            kk = min(k, 2 * m)
            _, idx = tree.query(here, k=kk)
            idx = np.atleast_1d(idx)
            free = idx[~done[idx // 2]]
            if len(free):
                nxt = int(free[0])
            elif kk == 2 * m:
                break
            k *= 4
        if nxt < 0:
            break
        j, rev = nxt // 2, bool(nxt % 2)
        order.append((j, rev))
        done[j] = True
        here = lines[j][0] if rev else lines[j][-1]
    return order
