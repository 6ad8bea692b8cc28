"""The persistent cache of results a re-export can reuse: stress analyses and engine paths, on disk.

A post-processor runs at every export (PrusaSlicer) or every slice (OrcaSlicer, Bambu Studio); most
re-exports change speeds, temperatures or other settings that neither the stress analysis nor the
paths depend on.  :class:`Cache` keeps those results under a hash of exactly what determines them
(the callers build the keys: :func:`loadpath.geometry.layers.islands_key` for one layer's islands,
:func:`loadpath.cache.fea_key` for a body's analysis,
:func:`loadpath.pipeline.paths.job_key` for one engine run), so the next run loads them instead.

Where: ``$LOADPATH_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/loadpath``, else
``~/.cache/loadpath`` (:func:`default_folder`); one sub-folder per kind of entry (``islands``,
``fea``, ``paths``, ``simplified``, ``links``, ``prediction``, ``beads``).  ``loadpath run --no-cache`` (setting
``cache = false``) neither reads nor writes it.

Safety:

* every key also hashes the loadpath version and the bytes of its own source files
  (:func:`code_stamp`), so an edited or upgraded loadpath never reads an older one's results;
* an entry is written to a temporary file in its folder and renamed into place (``os.replace``),
  so a reader sees a whole entry or none, also with several runs writing the same key at once
  (the last rename wins; both wrote the same result);
* an entry carries the SHA-256 of its payload: a torn, truncated or otherwise damaged one (or one
  that does not unpickle) is ignored, deleted and rebuilt by the caller;
* the folder is bounded (``max_bytes``, default 1 GiB, ``$LOADPATH_CACHE_MAX_MB``): a write that
  takes it over deletes the least recently used entries (modification time, refreshed on every hit)
  until it holds at most 90 % of the bound (:data:`LOW_WATER`, so the next runs' writes fit without
  another round); temporary files of runs that died are deleted after an hour.  Finding them means
  a ``stat`` of every entry (0.1-0.2 s for the 18 000 entries of a full 1 GiB folder), so a ledger
  (``.usage``, under an ``flock``) keeps the folder's bytes as the last such scan found them plus
  every write since; only a write that could take the folder over its bound scans it (and rewrites
  the ledger with what it found).  Deletions the ledger does not hear of (a damaged entry, another
  tool) only make it count high, which brings the next scan early.  Without ``fcntl`` (Windows),
  or with a bound on the number of entries, every write scans as before.

Entries are pickles, so the folder is created 0700: only the user's own runs write it.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pickle
import secrets
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "Cache",
    "CacheStats",
    "default_folder",
    "code_stamp",
    "source_stamp",
    "digest",
    "geometry_bytes",
    "fea_key",
]

ENV_DIR = "LOADPATH_CACHE_DIR"
ENV_MAX_MB = "LOADPATH_CACHE_MAX_MB"
DEFAULT_MAX_BYTES = 1 << 30
_MAGIC = b"LPC1"
_SUFFIX = ".entry"
_STALE_TMP_S = 3600.0
_LEDGER = ".usage"
LOW_WATER = 0.9
"""A folder found over its bound is cut to this share of it, so the next runs' writes fit without a scan."""

try:
    import fcntl
except ImportError:  # Windows: no ledger, every write scans the folder
    fcntl = None  # type: ignore[assignment]


def default_folder(env: dict[str, str] | None = None) -> Path:
    """Return the cache folder: ``$LOADPATH_CACHE_DIR``, ``$XDG_CACHE_HOME/loadpath``, ``~/.cache/loadpath``.

    ``env`` defaults to ``os.environ``.
    """
    env = os.environ if env is None else env
    if env.get(ENV_DIR):
        return Path(env[ENV_DIR]).expanduser()
    base = env.get("XDG_CACHE_HOME")
    if not base:
        try:
            base = str(Path.home() / ".cache")
        except RuntimeError:  # no home folder (a service account): a per-user temporary folder
            import tempfile

            return Path(tempfile.gettempdir()) / f"loadpath-cache-{os.getuid()}"
    return Path(base).expanduser() / "loadpath"


_STAMP: str | None = None

UNRELATED = ("gcode", "splice", "report", "plugin", "stiffness", "examples", "prusaslicer_postproc")
"""Sub-packages of loadpath no cached result depends on (reading and writing G-code, reports, the
front ends): editing them keeps the cache.  Everything else is in :func:`code_stamp`."""


def code_stamp() -> str:
    """Hash of the loadpath version and the bytes of the package's ``.py`` files (once per process).

    Every file but those under :data:`UNRELATED` (and this module), so a result made by one version
    of the geometry, FEA or engine code is never read by another.  About 5 ms.
    """
    global _STAMP
    if _STAMP is None:
        import loadpath

        h = hashlib.sha256(f"loadpath {loadpath.__version__}\n".encode())
        roots = sorted({Path(p).resolve() for p in loadpath.__path__})
        for root in roots:
            for p in sorted(root.rglob("*.py")):
                rel = p.relative_to(root)
                if rel.parts[0] in UNRELATED or rel.parts == ("cache.py",):
                    continue
                h.update(str(rel).encode() + b"\0")
                h.update(p.read_bytes())
        _STAMP = h.hexdigest()
    return _STAMP


_SOURCE_STAMPS: dict[str, str] = {}


def source_stamp(sub: str) -> str:
    """Hash of the ``.py`` files of one sub-package of :data:`UNRELATED` (once per process).

    For an entry that depends on such a package (the verdict's prediction on ``stiffness``) besides
    everything :func:`code_stamp` covers.
    """
    if sub not in _SOURCE_STAMPS:
        import loadpath

        h = hashlib.sha256(f"loadpath {loadpath.__version__} {sub}\n".encode())
        for root in sorted({Path(p).resolve() for p in loadpath.__path__}):
            for p in sorted((root / sub).rglob("*.py")):
                h.update(str(p.relative_to(root)).encode() + b"\0")
                h.update(p.read_bytes())
        _SOURCE_STAMPS[sub] = h.hexdigest()
    return _SOURCE_STAMPS[sub]


def digest(parts: Iterable[bytes | str]) -> str:
    """Return the hex SHA-256 of the parts, each length-prefixed (so no two lists collide)."""
    h = hashlib.sha256()
    for p in parts:
        b = p.encode() if isinstance(p, str) else bytes(p)
        h.update(len(b).to_bytes(8, "little"))
        h.update(b)
    return h.hexdigest()


def geometry_bytes(geom: Any, grid: float = 1e-3) -> bytes:
    """Return a canonical byte form of a shapely geometry: snapped to ``grid`` mm, normalised, WKB."""
    import shapely

    if geom is None:
        return b"none"
    return shapely.to_wkb(shapely.normalize(shapely.set_precision(geom, grid)), hex=False)


def fea_key(rb: Any, pitch: float | None) -> str:
    """Key of a body's stress analysis: what :func:`loadpath.fea.analyze` depends on.

    The body's slabs (heights to 0.1 µm, outlines to 1 µm), the analysis kind, the load case's
    supports, loads, material, frame and object (not its ``[toolpath]`` table), the pitch the
    default mesh size comes from (to 1 µm), and :func:`code_stamp`.
    """
    parts = _fea_parts(rb, pitch)
    for slab in rb.body.slabs:
        parts.append(geometry_bytes(slab.outline))
    return digest(parts)


def fea_near_key(rb: Any, pitch: float | None) -> str:
    """Key of a body's stress analysis for a near match: :func:`fea_key`'s without the outlines, which
    :func:`loadpath.pipeline.near_body` compares within ``TOL.region_reuse_mm``."""
    return digest(["near", *_fea_parts(rb, pitch)])


def _fea_parts(rb: Any, pitch: float | None) -> list[bytes | str]:
    """What :func:`fea_key` and :func:`fea_near_key` both name: all but the slabs' outlines."""
    lc = rb.loadcase
    parts: list[bytes | str] = [
        "fea",
        code_stamp(),
        str(rb.analysis),
        "none" if pitch is None else f"{float(pitch):.3f}",
        repr((lc.version, lc.supports, lc.loads, lc.material, lc.frame, lc.object)),
        repr(getattr(rb, "origin", None)),
    ]
    parts += [f"{slab.z0:.4f} {slab.z1:.4f}" for slab in rb.body.slabs]
    return parts


NEAR_KEEP = 3
"""Most entries kept under one near key by default (:meth:`Cache.keep_near`: analyses, engine runs,
linkings; the predictions keep more, :data:`loadpath.stiffness.change.NEAR_KEEP`)."""


@dataclass
class CacheStats:
    """Lookups of one :class:`Cache` object, per kind: ``hits``, ``misses``, ``corrupt`` (ignored entries),
    and ``kept`` (entries written: for an analysis, one solved; an exact miss served by a near match
    is not one)."""

    hits: dict[str, int] = field(default_factory=dict)
    misses: dict[str, int] = field(default_factory=dict)
    corrupt: dict[str, int] = field(default_factory=dict)
    kept: dict[str, int] = field(default_factory=dict)

    def count(self, table: dict[str, int], kind: str) -> None:
        table[kind] = table.get(kind, 0) + 1


class Cache:
    """A folder of results under keys (see the module docstring).

    Parameters
    ----------
    folder : Path, optional
        Default :func:`default_folder`.
    max_bytes : int, optional
        Size bound of the whole folder; default ``$LOADPATH_CACHE_MAX_MB`` MiB, else 1 GiB.
    max_entries : int, optional
        Bound on the number of entries of each kind (``loadpath serve --fea-cache-entries``).
    """

    def __init__(
        self,
        folder: str | os.PathLike | None = None,
        max_bytes: int | None = None,
        max_entries: int | None = None,
    ) -> None:
        self.folder = Path(folder) if folder is not None else default_folder()
        if max_bytes is None:
            mb = os.environ.get(ENV_MAX_MB)
            max_bytes = int(float(mb) * (1 << 20)) if mb else DEFAULT_MAX_BYTES
        self.max_bytes = int(max_bytes)
        self.max_entries = max_entries
        self.stats = CacheStats()
        self._written = 0  # bytes this instance wrote that the ledger has not heard of yet

    def path(self, kind: str, key: str) -> Path:
        """Return the file of an entry."""
        return self.folder / kind / f"{key}{_SUFFIX}"

    def get(self, kind: str, key: str) -> Any | None:
        """Return the value kept under ``key`` (None when absent or damaged; a damaged one is deleted)."""
        p = self.path(kind, key)
        try:
            with p.open("rb") as fh:
                blob = fh.read()
        except OSError:
            self.stats.count(self.stats.misses, kind)
            return None
        value = _decode(blob)
        if value is None:
            self.stats.count(self.stats.corrupt, kind)
            self.stats.count(self.stats.misses, kind)
            p.unlink(missing_ok=True)
            return None
        try:
            os.utime(p)  # least recently used = oldest modification time
        except OSError:  # deleted by another run's eviction meanwhile: the value is whole anyway
            pass
        self.stats.count(self.stats.hits, kind)
        return value

    def put(self, kind: str, key: str, value: Any, evict: bool = True) -> bool:
        """Keep ``value`` under ``key`` (atomically), then evict down to ``max_bytes``.

        ``evict=False`` leaves the eviction (a scan of the folder) to one :meth:`evict` call after a
        series of puts.

        Returns False (and keeps nothing) when the folder cannot be written, e.g. a read-only home:
        the run goes on without the cache.
        """
        payload = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
        blob = _MAGIC + hashlib.sha256(payload).digest() + payload
        if len(blob) > self.max_bytes:
            return False
        p = self.path(kind, key)
        tmp = p.with_name(f".{p.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
        try:
            self.folder.mkdir(parents=True, exist_ok=True, mode=0o700)
            p.parent.mkdir(exist_ok=True, mode=0o700)
            with tmp.open("wb") as fh:
                fh.write(blob)
            os.replace(tmp, p)
        except OSError:
            tmp.unlink(missing_ok=True)
            return False
        self._written += len(blob)
        self.stats.count(self.stats.kept, kind)
        if evict:
            self.evict()
        return True

    def near(self, kind: str, key: str) -> list[tuple[str, Any]]:
        """The entries kept under a near key (:meth:`keep_near`): ``(exact key, probe)``, newest first.

        A near key names what a result depends on but for what is matched within tolerances (a
        re-slice moves the slicer's geometry by micrometres); the caller compares each probe, then
        reads the result under its exact key (:func:`loadpath.stiffness.change.near_key`,
        :func:`loadpath.pipeline.paths.job_near_key`, the links' near key).
        """
        rec = self.get(kind, key)
        if not isinstance(rec, list):
            return []
        return [r for r in rec if isinstance(r, tuple) and len(r) == 2 and isinstance(r[0], str)]

    def keep_near(self, kind: str, key: str, exact: str, probe: Any, most: int = NEAR_KEEP) -> bool:
        """Add ``(exact, probe)`` to the entries under near key ``key`` (the newest ``most`` stay).

        Read, then written whole: two runs keeping at once may lose one of their entries (a later
        run then misses it and makes it again), never tear one.
        """
        kept = [r for r in self.near(kind, key) if r[0] != exact]
        return self.put(kind, key, [(exact, probe), *kept][:most], evict=False)

    def entries(self) -> list[tuple[float, int, Path]]:
        """``(mtime, bytes, path)`` of every entry, least recently used first."""
        out = []
        if not self.folder.is_dir():
            return out
        now = time.time()
        for sub in self.folder.iterdir():
            if not sub.is_dir():
                continue
            for p in sub.iterdir():
                try:
                    st = p.stat()
                except FileNotFoundError:  # evicted by another run meanwhile
                    continue
                if p.name.endswith(".tmp"):
                    if now - st.st_mtime > _STALE_TMP_S:  # left by a run that died
                        p.unlink(missing_ok=True)
                    continue
                if p.name.endswith(_SUFFIX):
                    out.append((st.st_mtime, st.st_size, p))
        out.sort(key=lambda e: (e[0], str(e[2])))
        return out

    def size(self) -> int:
        """Bytes held by the entries."""
        return sum(s for _, s, _ in self.entries())

    def count(self, kind: str) -> int:
        """Number of entries of one kind."""
        return sum(1 for _, _, p in self.entries() if p.parent.name == kind)

    def evict(self) -> int:
        """Delete least recently used entries beyond ``max_bytes`` (down to :data:`LOW_WATER` of it) and
        ``max_entries``; returns how many.

        The folder is scanned only when the ledger (module docstring) says the writes since its last
        scan could have taken it over ``max_bytes``, when there is no usable ledger, or with
        ``max_entries``.
        """
        with self._ledger() as ledger:
            if ledger is not None and self.max_entries is None:
                known = _read_ledger(ledger)
                if known is not None and known + self._written <= self.max_bytes:
                    _write_ledger(ledger, known + self._written)
                    self._written = 0
                    return 0
            gone, total = self._scan_evict()
            if ledger is not None:
                _write_ledger(ledger, total)
            self._written = 0
            return gone

    @contextlib.contextmanager
    def _ledger(self):  # type: ignore[no-untyped-def]
        """The ledger file, open and locked (None without ``fcntl`` or when it cannot be opened)."""
        if fcntl is None:
            yield None
            return
        try:
            self.folder.mkdir(parents=True, exist_ok=True, mode=0o700)
            fh = open(self.folder / _LEDGER, "a+b")  # noqa: SIM115 - closed below, after the unlock
        except OSError:
            yield None
            return
        try:
            fcntl.flock(fh, fcntl.LOCK_EX)
            yield fh
        finally:
            fh.close()  # releases the lock

    def _scan_evict(self) -> tuple[int, int]:
        """Scan the folder and delete as :meth:`evict` says; ``(deleted, bytes left)``."""
        entries = self.entries()
        total = sum(s for _, s, _ in entries)
        per_kind: dict[str, int] = {}
        for _, _, p in entries:
            per_kind[p.parent.name] = per_kind.get(p.parent.name, 0) + 1
        gone = 0
        bound = self.max_bytes if total <= self.max_bytes else int(LOW_WATER * self.max_bytes)
        for _, s, p in entries:
            kind = p.parent.name
            over_count = self.max_entries is not None and per_kind[kind] > self.max_entries
            if total <= bound and not over_count:
                continue
            p.unlink(missing_ok=True)
            total -= s
            per_kind[kind] -= 1
            gone += 1
        return gone, total


def _read_ledger(fh) -> int | None:  # type: ignore[no-untyped-def]
    """The bytes the ledger holds, or None when it is empty or not a number (a new or damaged one)."""
    fh.seek(0)
    text = fh.read(64)
    try:
        n = int(text.decode("ascii").strip())
    except (UnicodeDecodeError, ValueError):
        return None
    return n if n >= 0 else None


def _write_ledger(fh, n: int) -> None:  # type: ignore[no-untyped-def]
    fh.seek(0)
    fh.truncate()
    fh.write(str(int(n)).encode("ascii"))
    fh.flush()


def _decode(blob: bytes) -> Any | None:
    """Return the value of an entry's bytes, or None when they are not a whole, intact entry."""
    n = len(_MAGIC)
    if len(blob) < n + 32 or blob[:n] != _MAGIC:
        return None
    payload = blob[n + 32 :]
    if hashlib.sha256(payload).digest() != blob[n : n + 32]:
        return None
    try:
        return pickle.loads(payload)
    except Exception:  # noqa: BLE001 - any unpickling failure means: not usable, rebuild it
        return None
