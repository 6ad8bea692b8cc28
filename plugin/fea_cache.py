"""The FEA cache of ``loadpath serve``: solved stress analyses kept per part and load case.

Solving the stress analysis is the part of a run that does not depend on the print settings.
:class:`FEACache` is an ``analyze(rb, pitch=...)`` for :func:`loadpath.pipeline.run` that keeps each
solved :class:`~loadpath.fea.Analysis` under :func:`fea_key`: a hash of the part outlines (per slab,
at 1 µm), the load case's supports, loads, material, frame and object, and the loadpath version.
Re-slicing with other print settings (infill, speeds, temperatures) reuses it; a changed outline or
load case solves again.  At most ``max_entries`` results are kept (least recently used dropped).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pickle
import uuid
from pathlib import Path
from typing import Any

__all__ = ["FEACache", "fea_key"]


def fea_key(rb: Any) -> str:
    """Hash of what a stress analysis depends on: outlines, load case (without [toolpath]), version."""
    import shapely
    from loadpath import __version__

    h = hashlib.sha256(f"loadpath {__version__}\n{rb.analysis}\n".encode())
    for slab in rb.body.slabs:
        h.update(f"{slab.z0:.4f} {slab.z1:.4f}\n".encode())
        outline = shapely.normalize(shapely.set_precision(slab.outline, 1e-3))
        h.update(shapely.to_wkb(outline, hex=False))
    lc = rb.loadcase
    h.update(repr((lc.version, lc.supports, lc.loads, lc.material, lc.frame, lc.object)).encode())
    return h.hexdigest()[:32]


class FEACache:
    """``analyze(rb, pitch=...)`` that reuses solved analyses kept in ``folder`` (pickles).

    Only this service writes the folder (mode 0700 under the user's cache), so its pickles are
    trusted.  ``hits`` and ``misses`` count this instance's lookups.
    """

    def __init__(self, folder: Path, max_entries: int = 64) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        self.max_entries = max_entries
        self.hits = 0
        self.misses = 0

    def __call__(self, rb: Any, pitch: float | None = None, **kw: Any) -> Any:
        """Return the cached analysis of ``rb`` (attached to ``rb``), else solve and keep it."""
        from loadpath import fea

        path = self.folder / f"{fea_key(rb)}.pickle"
        if path.is_file():
            try:
                with path.open("rb") as fh:
                    cached = pickle.load(fh)
                os.utime(path)
                self.hits += 1
                return dataclasses.replace(cached, resolved=rb, _cache={})
            except (OSError, pickle.UnpicklingError, EOFError, AttributeError, TypeError):
                path.unlink(missing_ok=True)  # damaged or from another version: solve again
        analysis = fea.analyze(rb, pitch=pitch, **kw)
        self.misses += 1
        tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
        with tmp.open("wb") as fh:
            pickle.dump(dataclasses.replace(analysis, _cache={}), fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
        self.prune()
        return analysis

    def entries(self) -> list[Path]:
        """List the cached results, least recently used first."""
        stamped = []
        for p in self.folder.glob("*.pickle"):
            try:
                stamped.append((p.stat().st_mtime, p))
            except FileNotFoundError:  # pruned by another job meanwhile
                continue
        return [p for _, p in sorted(stamped)]

    def prune(self) -> None:
        """Drop the least recently used results beyond ``max_entries``."""
        entries = self.entries()
        for p in entries[: max(0, len(entries) - self.max_entries)]:
            p.unlink(missing_ok=True)
