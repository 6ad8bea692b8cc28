"""Kills at chosen stages (#20): no process left, no temp file left, the input untouched, one line.

``loadpath run`` runs as a real subprocess in its own session (its own process group, as a shell
job is) on real PrusaSlicer output with two workers.  A stage is chosen by watching the process:
"paths" is the moment its worker processes exist (the parallel paths stage).  Then:

- Ctrl-C (SIGINT to the whole process group, as a terminal sends it): one line, exit 130, no worker
  tracebacks (before: 32-38 lines of ``KeyboardInterrupt`` from the workers);
- SIGTERM: the same as SIGINT, exit 143;
- SIGKILL: the workers die with their parent (before: two ~113 MB workers re-parented to init and
  blocked for as long as anyone watched).

Afterwards no process of the group is alive (checked in ``/proc``), the folder holds only the input
and the load case (no hidden ``.OUT.xxxx.tmp``), and the input's checksum is unchanged.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cases import GRIP_PULL

LOADPATH = [sys.executable, "-m", "loadpath.plugin.cli"]


def _group_alive(pgid: int) -> list[int]:
    """Pids (not zombies) whose process group is ``pgid``."""
    out = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                fields = Path(f"/proc/{name}/stat").read_bytes().rsplit(b")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == pgid and fields[0] != b"Z":
                out.append(int(name))
    return out


def _children(pid: int) -> list[int]:
    from loadpath.procs import children_of

    return children_of(pid)


def _wait_gone(pgid: int, timeout: float = 15.0) -> list[int]:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        alive = _group_alive(pgid)
        if not alive:
            return []
        time.sleep(0.1)
    return _group_alive(pgid)


@pytest.fixture()
def job(tmp_path, sliced):
    src = sliced("prusa", "ohs", "mixed")
    g = tmp_path / "part.gcode"
    shutil.copyfile(src, g)
    case = tmp_path / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    return tmp_path, g, case


def _start(g: Path, case: Path, *extra: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("LOADPATH_DEBUG", None)
    return subprocess.Popen(
        [*LOADPATH, "run", str(g), "--loadcase", str(case), "--set", "jobs=2", "--replace", "solid,sparse", *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True, env=env,
    )


def _wait_for_workers(p: subprocess.Popen, timeout: float = 240.0) -> list[int]:
    end = time.monotonic() + timeout
    while time.monotonic() < end and p.poll() is None:
        kids = [k for k in _children(p.pid) if _cmd(k) and "resource_tracker" not in _cmd(k)]
        if len(kids) >= 2:
            return kids
        time.sleep(0.05)
    raise AssertionError(f"no paths-stage workers appeared (exit {p.poll()}): {p.stderr.read()!r}")


def _cmd(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _check_clean(folder: Path, g: Path, digest: str, pgid: int) -> None:
    assert _wait_gone(pgid) == [], "processes of the killed job are still alive"
    assert sorted(p.name for p in folder.iterdir()) == ["case.toml", "part.gcode"]
    assert hashlib.sha256(g.read_bytes()).hexdigest() == digest


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm", "sigkill"])
def test_kill_in_the_paths_stage_leaves_nothing(job, how):
    folder, g, case = job
    digest = hashlib.sha256(g.read_bytes()).hexdigest()
    p = _start(g, case)
    pgid = p.pid
    try:
        _wait_for_workers(p)
        if how == "ctrl-c":
            os.killpg(pgid, signal.SIGINT)
        elif how == "sigterm":
            os.kill(p.pid, signal.SIGTERM)
        else:
            os.kill(p.pid, signal.SIGKILL)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            os.killpg(pgid, signal.SIGKILL)
    err = err.decode().strip()
    if how == "sigkill":
        assert p.returncode == -signal.SIGKILL
    else:
        assert p.returncode == (130 if how == "ctrl-c" else 143), err
        assert err.count("\n") == 0 and "Traceback" not in err, err
        assert err == ("loadpath: interrupted (Ctrl-C): stopped; no file was written" if how == "ctrl-c"
                       else "loadpath: terminated (SIGTERM): stopped; no file was written")
    _check_clean(folder, g, digest, pgid)


@pytest.mark.parametrize("delay", [0.3, 1.5])
def test_sigterm_early_leaves_nothing(job, delay):
    """SIGTERM while the file is read or the layers derived (before any worker)."""
    folder, g, case = job
    digest = hashlib.sha256(g.read_bytes()).hexdigest()
    p = _start(g, case)
    time.sleep(delay)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    err = err.decode().strip()
    assert p.returncode in (143, -signal.SIGTERM), err  # -15: before the handler was installed
    assert "Traceback" not in err and err.count("\n") <= 0
    _check_clean(folder, g, digest, p.pid)


def test_sigterm_in_the_write_window_removes_the_temp_file(job, monkeypatch):
    """A signal that arrives while the temp file exists (after its data is on disk, before the rename):
    the write window is microseconds long on a real disk, so the signal is raised from inside it."""
    from loadpath.plugin import job as job_mod
    from loadpath.plugin.lifecycle import Interrupted

    folder, g, case = job
    real_fsync = os.fsync

    def fsync_then_sigterm(fd):
        real_fsync(fd)
        assert [p.name for p in folder.iterdir() if p.name.startswith(".out.gcode.")]  # temp exists
        raise Interrupted(signal.SIGTERM)

    monkeypatch.setattr(job_mod.os, "fsync", fsync_then_sigterm)
    with pytest.raises(Interrupted):
        job_mod.write_atomic(folder / "out.gcode", b"G1 X1\n")
    assert sorted(p.name for p in folder.iterdir()) == ["case.toml", "part.gcode"]


def test_batch_sigterm_stops_its_workers_and_says_what_was_written(tmp_path, sliced):
    """``batch`` of three files, two at once: SIGTERM once its worker processes run.  Before: the
    forkserver, resource tracker and workers stayed, and Ctrl-C said "no file was written" after
    writing two."""
    src = sliced("prusa", "ohs", "mixed")
    files = []
    for i in range(3):
        f = tmp_path / f"p{i}.gcode"
        shutil.copyfile(src, f)
        files.append(f)
    digests = {f: hashlib.sha256(f.read_bytes()).hexdigest() for f in files}
    case = tmp_path / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    out = tmp_path / "out"
    env = {**os.environ}
    env.pop("LOADPATH_DEBUG", None)
    p = subprocess.Popen([*LOADPATH, "batch", *map(str, files), "--loadcase", str(case), "--out", str(out),
                          "--jobs", "2", "--no-metrics", "--replace", "solid,sparse"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True, env=env)
    try:
        end = time.monotonic() + 240
        while time.monotonic() < end and p.poll() is None:  # forkserver workers: grandchildren
            if any(_children(k) for k in _children(p.pid)):
                break
            time.sleep(0.1)
        time.sleep(2.0)
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=90)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    err = err.decode().strip().splitlines()
    assert p.returncode == 143, err
    assert "Traceback" not in "\n".join(err)
    last = err[-1]
    assert last.startswith("loadpath: terminated (SIGTERM): stopped; ")
    written = sorted(q.name for q in out.iterdir()) if out.exists() else []
    assert not [n for n in written if n.startswith(".")]  # no temp file
    if written:
        assert all(str(out / n) in last for n in written)
    else:
        assert last.endswith("no file was written")
    assert _wait_gone(p.pid) == []
    assert all(hashlib.sha256(f.read_bytes()).hexdigest() == d for f, d in digests.items())


_CALLBACK_WORKER = '''
import ctypes, time
from loadpath.procs import worker_init

worker_init(None, True)


def compiled_code_cache_notify():  # Python code C calls back, as llvmlite does for numba's cache
    end = time.monotonic() + 5
    while time.monotonic() < end:
        time.sleep(0.01)


try:
    print("ready", flush=True)
    ctypes.CFUNCTYPE(None)(compiled_code_cache_notify)()
    time.sleep(5)  # a worker goes on working after the callback
    print("worked on", flush=True)
finally:
    print("cleaned", flush=True)
'''


def test_sigterm_inside_a_c_callback_still_stops_a_worker_cleanly(tmp_path):
    """A clean-exit worker's SIGTERM arriving while C has called back into Python (numba loading a
    compiled kernel, in a batch worker): the handler's SystemExit cannot leave the callback.  Before,
    Python printed it as "Exception ignored on calling ctypes callback function" with a traceback
    under batch's one-line stop message (a full suite run), and the worker went on working."""
    script = tmp_path / "worker.py"
    script.write_text(_CALLBACK_WORKER, encoding="utf-8")
    p = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        assert p.stdout.readline() == b"ready\n"
        time.sleep(0.5)
        p.send_signal(signal.SIGTERM)
        out, err = p.communicate(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 143, (out, err)
    assert out == b"cleaned\n", out  # its finally ran; it did not go on working
    assert b"Traceback" not in err and b"Exception ignored" not in err, err.decode()
