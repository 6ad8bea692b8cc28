"""Session fixtures with real slicer output, shared by every test folder.

Registered by one line at the bottom of ``tests/conftest.py``.  Each fixture builds its STL, runs the
real slicer (``tests/slicing.py``) once per test session into a cached temporary folder, and returns
the path of the G-code.  Tests that use them need the slicer: outside CI they skip with the apt
command, in CI (``CI=true``) they fail (``require_tool``).

Usage::

    def test_something(prusa_ohs):           # Path to PrusaSlicer 2.5 G-code of the specimen
        program = loadpath.gcode.read(prusa_ohs)

    def test_other(sliced):                   # factory for any part/slicer/settings combination
        path = sliced("cura", "bracket", "solid")

Parts: ``ohs``, ``two_islands``, ``bracket``, ``tower``, ``two_objects`` (the specimen's two
neighbours ``two_islands`` + ``bracket`` as two separate objects on one bed).  Settings: ``mixed``
(20 % sparse + 2 solid layers top and bottom) and ``solid`` (100 %); see ``tests/slicing.py``.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import conftest as _root_conftest  # tests/conftest.py, which imports this module at its end
import pytest
import slicing

__all__ = [
    "without_verdict",
    "made_once",
    "slice_cache",
    "sliced",
    "test_stls",
    "prusa_ohs",
    "prusa_ohs_solid",
    "prusa_two_islands",
    "prusa_bracket",
    "prusa_tower",
    "prusa_two_objects",
    "cura_ohs",
    "cura_ohs_solid",
    "cura_two_islands",
    "cura_bracket",
    "cura_tower",
    "cura_two_objects",
]

def without_verdict(data: bytes) -> bytes:
    """G-code without loadpath's verdict line, which carries the minute of the run.

    Two runs of the same job give the same file but for that line: the owner of the line says
    what it is (:func:`loadpath.verdict.without_header`).
    """
    from loadpath.verdict import without_header

    return without_header(data)


def load_script(path: Path, name: str):  # type: ignore[no-untyped-def]
    """The file at ``path`` (a script, or a plugin file Cura or the service loads) run as module ``name``.

    Not entered in ``sys.modules``: each call is a fresh module, as its host program loads it.
    """
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_SETTINGS = {
    "prusa": {"mixed": slicing.PRUSA_MIXED, "solid": slicing.PRUSA_SOLID, "example": slicing.PRUSA_EXAMPLE},
    "cura": {"mixed": slicing.CURA_MIXED, "solid": slicing.CURA_SOLID},
}
_TOOL = {"prusa": "prusa-slicer", "cura": "CuraEngine"}
_lock = threading.RLock()


@contextlib.contextmanager
def _file_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive ``flock`` on ``path`` (created if missing) across processes."""
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def made_once(out: Path, make: Callable[[], object]) -> Path:
    """``out``, made by ``make()`` the first time any test process asks for it.

    The suite runs in several pytest-xdist worker processes that share :func:`slice_cache`: a lock
    file next to ``out`` lets one process make it while the others wait, and a ``.done`` marker
    (written after ``make`` returned) tells a finished file from one a failed or killed run left half
    written, which is made again.
    """
    done = out.with_name(out.name + ".done")
    with _lock, _file_lock(out.with_name(out.name + ".lock")):
        if not done.exists():
            make()
            done.touch()
    return out


@pytest.fixture(scope="session")
def slice_cache(tmp_path_factory) -> Path:
    """Folder where this run's STLs and sliced G-code are kept, shared by its xdist workers.

    Files in it are named by what made them (part, slicer, settings, a digest of the overrides), so
    two workers that ask for the same G-code get the same file, sliced once (:func:`made_once`).
    Without xdist (no ``PYTEST_XDIST_WORKER``, or ``-p no:xdist``) the folder is the session's own.
    """
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return tmp_path_factory.mktemp("sliced")
    shared = tmp_path_factory.getbasetemp().parent / "sliced"  # the run's basetemp, above popen-gwN/
    shared.mkdir(exist_ok=True)
    return shared


@pytest.fixture(scope="session")
def test_stls(slice_cache):
    """Factory ``test_stls(part) -> [Path, ...]``: the STL file(s) of a test part (one per object)."""

    def make(part: str) -> list[Path]:
        if part == "two_objects":
            return [*make("two_islands"), *make("bracket")]
        path = slice_cache / f"{part}.stl"
        return [made_once(path, lambda: slicing.write_stl(slicing.PARTS[part](), path))]

    return make


@pytest.fixture(scope="session")
def sliced(slice_cache, test_stls):
    """Factory ``sliced(slicer, part, settings="mixed", **overrides) -> Path`` of real G-code.

    ``slicer`` is ``"prusa"`` (PrusaSlicer 2.5, MK3S presets, relative E) or ``"cura"`` (CuraEngine
    4.13, prusa_i3_mk3, absolute E).  Results are cached for the run by their arguments, across
    xdist workers (:func:`slice_cache`).
    """

    def make(slicer: str, part: str, settings: str = "mixed", **overrides) -> Path:
        _root_conftest.require_tool(_TOOL[slicer])
        if slicer == "cura":
            _root_conftest.require_tool("cura")  # machine definitions
        extra = ""
        if overrides:  # a short digest: values may hold characters a slicer's --load splits on (';')
            key = repr(sorted((k, str(v)) for k, v in overrides.items())).encode()
            extra = "-" + hashlib.sha1(key).hexdigest()[:10]
        out = slice_cache / f"{slicer}-{part}-{settings}{extra}.gcode"

        def slice_it() -> None:
            stls = test_stls(part)
            conf = {**_SETTINGS[slicer][settings], **{k: str(v) for k, v in overrides.items()}}
            fn = slicing.slice_prusa if slicer == "prusa" else slicing.slice_cura
            fn(stls, out, **conf)

        return made_once(out, slice_it)

    return make


@pytest.fixture(scope="session")
def prusa_ohs(sliced) -> Path:
    """Specimen, PrusaSlicer 2.5: Solid infill (layers 1-2), Internal infill 20 % (3-8), Bridge, Top."""
    return sliced("prusa", "ohs", "mixed")


@pytest.fixture(scope="session")
def prusa_ohs_solid(sliced) -> Path:
    """Specimen, PrusaSlicer 2.5, 100 % rectilinear infill."""
    return sliced("prusa", "ohs", "solid")


@pytest.fixture(scope="session")
def prusa_two_islands(sliced) -> Path:
    return sliced("prusa", "two_islands", "mixed")


@pytest.fixture(scope="session")
def prusa_bracket(sliced) -> Path:
    return sliced("prusa", "bracket", "mixed")


@pytest.fixture(scope="session")
def prusa_tower(sliced) -> Path:
    """120 layers, outline changing with height (slow-ish: about 1 s to slice)."""
    return sliced("prusa", "tower", "mixed")


@pytest.fixture(scope="session")
def prusa_two_objects(sliced) -> Path:
    return sliced("prusa", "two_objects", "mixed")


@pytest.fixture(scope="session")
def cura_ohs(sliced) -> Path:
    """Specimen, CuraEngine 4.13: SKIN (layers 0-1, 8-9), FILL 20 % (2-7), absolute E."""
    return sliced("cura", "ohs", "mixed")


@pytest.fixture(scope="session")
def cura_ohs_solid(sliced) -> Path:
    return sliced("cura", "ohs", "solid")


@pytest.fixture(scope="session")
def cura_two_islands(sliced) -> Path:
    return sliced("cura", "two_islands", "mixed")


@pytest.fixture(scope="session")
def cura_bracket(sliced) -> Path:
    return sliced("cura", "bracket", "mixed")


@pytest.fixture(scope="session")
def cura_tower(sliced) -> Path:
    return sliced("cura", "tower", "mixed")


@pytest.fixture(scope="session")
def cura_two_objects(sliced) -> Path:
    return sliced("cura", "two_objects", "mixed")
