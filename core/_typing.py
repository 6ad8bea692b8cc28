"""Shared array aliases.  Shapes and units are given in each docstring that uses them."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from shapely.geometry import MultiPolygon, Polygon

Floats = npt.NDArray[np.float64]          # (n,)
Ints = npt.NDArray[np.int64]              # (n,)
Bools = npt.NDArray[np.bool_]             # (n,)
Points2 = npt.NDArray[np.float64]         # (n, 2)
Points3 = npt.NDArray[np.float64]         # (n, 3)
Vectors2 = npt.NDArray[np.float64]        # (n, 2)
Stress2 = npt.NDArray[np.float64]         # (n, 3): [sxx, syy, sxy]
Stress3 = npt.NDArray[np.float64]         # (n, 6): [sxx, syy, szz, syz, sxz, sxy]
Cells = npt.NDArray[np.int64]             # (m, k)
Region = Polygon | MultiPolygon
