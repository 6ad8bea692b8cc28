"""gmsh's mesher is bounded (#20): no outline can keep it running, and a stop signal ends it at once.

gmsh's ``generate(2)`` ran 9.4 min of CPU on fuzzed Cura brackets (a hole ring with a notch nearly
closing on itself) and ran on past a minute on an outline whose edge crosses a vertex's edge; the time
is in C, where Ctrl-C and SIGTERM do not reach.  Now an outline that crosses itself is refused before
gmsh, the mesher runs in a child process with a CPU-time budget (:func:`loadpath.budget.mesh_seconds`),
and the parent waits in Python.  The slow meshes here are real gmsh runs of a large plate; the
limits are lowered through :mod:`loadpath.budget` (read at call time) to reach them in seconds.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from loadpath import budget
from loadpath.errors import BudgetError
from loadpath.mesh import mesh_2d
from loadpath.procs import children_of
from shapely.geometry import Point, box

CROSSING = "Polygon([(0, 0), (20, 0), (20, 6), (900, 3.3), (0, 6)])"
"""A specimen with one wall vertex moved to x = 900: the spike's upper edge passes 0.06 mm below the
corner (20, 6), so the outline crosses itself there.  gmsh's ``generate(2)`` did not return within
60 s on it (killed)."""

_SLOW = f"""
import sys, time
from shapely.geometry import Point, box
from loadpath import budget
from loadpath.mesh import mesh_2d
from loadpath.plugin.lifecycle import Interrupted, terminate_as_interrupt
budget.MESH_ELEMENTS = 1e8
plate = box(0, 0, 150, 36).difference(Point(75, 18).buffer(3))
with terminate_as_interrupt():
    try:
        print("meshing", flush=True)
        mesh_2d(plate, 0.12)
        print("meshed", flush=True)
    except Interrupted as exc:
        print("stopped", flush=True)
        sys.exit(exc.status)
"""
"""A plate meshed at 0.12 mm: about 860,000 triangles, a minute or more of gmsh on the test machine."""


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie (a container's init may never reap it)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except OSError:
        return False


def _python(code: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, **kw)


def test_an_outline_crossing_itself_is_refused_before_gmsh():
    code = f"""
from shapely.geometry import Polygon
from loadpath.errors import MeshingError
from loadpath.mesh import mesh_2d
try:
    mesh_2d({CROSSING}, 2.0)
except MeshingError as exc:
    print(exc)
"""
    t0 = time.monotonic()
    p = _python(code)
    try:
        out, err = p.communicate(timeout=60)
    finally:
        os.killpg(p.pid, signal.SIGKILL) if p.poll() is None else None
    assert "crosses itself near (20.000, 5.940) mm" in out, (out, err)
    assert "check the walls at that place" in out
    assert time.monotonic() - t0 < 30


def test_the_mesher_is_stopped_at_its_time_budget(monkeypatch):
    monkeypatch.setattr(budget, "MESH_ELEMENTS", 1e8)
    monkeypatch.setattr(budget, "MESH_SECONDS", 1.0, raising=False)
    monkeypatch.setattr(budget, "MESH_SECONDS_PER_ELEMENT", 0.0, raising=False)
    plate = box(0, 0, 150, 36).difference(Point(75, 18).buffer(3))
    before = set(children_of(os.getpid()))  # earlier tests in this process may have left their own
    t0 = time.monotonic()
    with pytest.raises(BudgetError, match=r"gmsh's mesher did not finish within its time budget of 1 s CPU"):
        mesh_2d(plate, 0.2)  # about 310,000 triangles: 20 s or more of gmsh
    assert time.monotonic() - t0 < 30
    assert [pid for pid in children_of(os.getpid()) if pid not in before and _alive(pid)] == []


@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
def test_a_stop_during_meshing_ends_it_at_once_and_leaves_no_process(how):
    p = _python(_SLOW)
    try:
        assert p.stdout.readline().strip() == "meshing"
        end = time.monotonic() + 20
        while not children_of(p.pid) and time.monotonic() < end:
            time.sleep(0.1)
        helpers = children_of(p.pid)
        assert helpers, "gmsh's mesher runs in a child process"
        time.sleep(1.0)  # well inside generate(2)
        t0 = time.monotonic()
        os.kill(p.pid, getattr(signal, how))
        p.wait(timeout=30)
        took = time.monotonic() - t0
        out, err = p.communicate()
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    assert took < 5, took
    if how == "SIGTERM":
        assert p.returncode == 128 + signal.SIGTERM and out.strip() == "stopped" and err == "", (out, err)
    end = time.monotonic() + 10
    while any(map(_alive, helpers)) and time.monotonic() < end:
        time.sleep(0.1)
    assert not any(map(_alive, helpers)), "the mesher's child outlived its parent"
