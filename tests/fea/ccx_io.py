"""Write a CalculiX input deck from our mesh and load case, run ccx, read its results (.frd).

Used only by the cross-check tests: the deck carries the same mesh (CPS6 plane-stress triangles or
C3D10 tetrahedra, whose node orders are ours), the same supports (node sets, fixed directions) and
the same loads (our consistent nodal forces as *CLOAD, or *DLOAD pressures on element faces).
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np

# CalculiX face numbers: tri edges (1-2, 2-3, 3-1); tet faces (1-2-3, 1-4-2, 2-4-3, 3-4-1)
TRI_FACES = {frozenset((0, 1)): 1, frozenset((1, 2)): 2, frozenset((2, 0)): 3}
TET_FACES = {
    frozenset((0, 1, 2)): 1,
    frozenset((0, 3, 1)): 2,
    frozenset((1, 3, 2)): 3,
    frozenset((2, 3, 0)): 4,
}


def write_deck(
    path: Path,
    points: np.ndarray,
    cells: np.ndarray,
    cell_type: str,
    E: float,
    nu: float,
    fixed: dict[str, tuple[np.ndarray, tuple[int, ...]]],
    cload: np.ndarray | None = None,
    dload: list[tuple[int, int, float]] | None = None,
    thickness: float = 1.0,
) -> None:
    """Write ``path`` (a ``.inp`` file).

    Parameters
    ----------
    points : (n, 2 | 3) float
    cells : (m, 6 | 10) int, our order (= CalculiX's)
    cell_type : "tri6" or "tet10"
    fixed : name -> (nodes (k,), directions (1-based))
    cload : (n, d) float, optional
        Nodal forces, N.
    dload : list of (cell, face, pressure), optional
        Pressures on element faces (CalculiX face numbers), MPa.
    """
    n, d = points.shape
    p3 = np.column_stack([points, np.zeros(n)]) if d == 2 else points
    L = ["*HEADING", "loadpath cross-check", "*NODE, NSET=NALL"]
    L += [f"{i + 1}, {x:.12g}, {y:.12g}, {z:.12g}" for i, (x, y, z) in enumerate(p3)]
    etype = "CPS6" if cell_type == "tri6" else "C3D10"
    L.append(f"*ELEMENT, TYPE={etype}, ELSET=PART")
    for j, c in enumerate(cells + 1):
        L.append(f"{j + 1}, " + ", ".join(str(int(v)) for v in c))
    for name, (nodes, _) in fixed.items():
        L.append(f"*NSET, NSET={name}")
        ids = np.unique(nodes) + 1
        L += [", ".join(str(int(v)) for v in ids[k : k + 12]) for k in range(0, len(ids), 12)]
    L += ["*MATERIAL, NAME=MAT", "*ELASTIC", f"{E:.12g}, {nu:.12g}"]
    L += ["*SOLID SECTION, ELSET=PART, MATERIAL=MAT"]
    if cell_type == "tri6":
        L.append(f"{thickness:.12g}")
    L += ["*STEP", "*STATIC", "*BOUNDARY"]
    for name, (_, dirs) in fixed.items():
        L += [f"{name}, {a}, {a}, 0." for a in dirs]
    if cload is not None:
        # CalculiX reads at most 20 characters per number: "-2.77719097980639e-31" would lose its
        # exponent's last digit and become -2.8e-3, so write 12 digits and leave out round-off zeros
        L.append("*CLOAD")
        small = 1e-12 * float(np.abs(cload).max())
        for i, f in enumerate(cload):
            for a in range(d):
                if abs(f[a]) > small:
                    L.append(f"{i + 1}, {a + 1}, {f[a]:.12g}")
    if dload:
        L.append("*DLOAD")
        L += [f"{c + 1}, P{face}, {p:.12g}" for c, face, p in dload]
    L += ["*NODE FILE", "U", "*EL FILE", "S", "*NODE PRINT, NSET=NALL, TOTALS=ONLY", "RF", "*END STEP"]
    path.write_text("\n".join(L) + "\n")


def run(deck: Path, timeout: float = 600.0) -> subprocess.CompletedProcess:
    """Run ``ccx -i <job>`` in the deck's folder; raise with the log tail on failure."""
    env = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_STIFFNESS="1", CCX_NPROC_EQUATION_SOLVER="1")
    res = subprocess.run(
        ["ccx", "-i", deck.stem], cwd=deck.parent, capture_output=True, text=True, timeout=timeout, env=env
    )
    if res.returncode != 0 or "ERROR" in res.stdout:
        raise RuntimeError(f"ccx failed ({res.returncode}):\n{res.stdout[-2000:]}\n{res.stderr[-2000:]}")
    return res


def read_frd(path: Path, n_nodes: int) -> dict[str, np.ndarray]:
    """Nodal blocks of a ``.frd`` result file (first step): ``DISP`` (n, 3) and ``STRESS`` (n, 6).

    Stress components in CalculiX order ``SXX SYY SZZ SXY SYZ SZX``. Nodes beyond ``n_nodes``
    (those CalculiX adds when it expands plane elements) are dropped.
    """
    out: dict[str, np.ndarray] = {}
    name = None
    rows: list[tuple[int, list[float]]] = []
    for line in path.read_text().splitlines():
        if line.startswith(" -4"):
            name = line[3:].split()[0]
            rows = []
            continue
        if name is None:
            continue
        if line.startswith(" -1"):
            node = int(line[3:13])
            vals = [float(line[13 + 12 * i : 25 + 12 * i]) for i in range((len(line) - 13) // 12)]
            rows.append((node, vals))
        elif line.startswith(" -3"):
            if name not in out:
                k = max(len(v) for _, v in rows)
                arr = np.full((n_nodes, k), np.nan)
                for node, vals in rows:
                    if node <= n_nodes:
                        arr[node - 1, : len(vals)] = vals
                out[name] = arr
            name = None
    return out


def to_voigt(ccx_stress: np.ndarray, dim: int) -> np.ndarray:
    """Reorder CalculiX ``SXX SYY SZZ SXY SYZ SZX`` into ours.

    2D ``[sxx, syy, sxy]``, 3D ``[sxx, syy, szz, syz, sxz, sxy]``.
    """
    s = ccx_stress
    if dim == 2:
        return s[:, [0, 1, 3]]
    return s[:, [0, 1, 2, 4, 5, 3]]
