"""Worker processes that die with their parent, and pools that are stopped, not waited for.

Every process pool of loadpath (the parallel paths stage, ``batch``, the service's job processes)
starts its workers through :func:`worker_init`:

- on Linux the kernel sends the worker SIGKILL when its parent dies (``prctl(PR_SET_PDEATHSIG)``
  through ctypes), so a ``kill -9`` of ``loadpath run`` no longer leaves two 113 MB workers
  re-parented to init; a forkserver's workers die with the forkserver, which exits when its parent does;
- everywhere a daemon thread checks once a second that the parent is still the one that started the
  worker (the orphan check: the death signal is not inherited across exec and not on every OS);
- SIGINT is ignored in workers: Ctrl-C reaches the whole foreground process group, and the parent
  alone turns it into one line and stops the workers (:func:`stop_pool`), instead of every worker
  printing its own ``KeyboardInterrupt`` traceback.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

__all__ = [
    "Interrupted", "raise_if_stopped", "worker_init", "die_with_parent", "stop_pool", "forks", "fork_map",
    "children_of", "warm_start_method", "in_child", "OverLimit", "ChildCrashed",
]

_PR_SET_PDEATHSIG = 1
_pending = [0]  # the signal that asked this process to stop (set by loadpath.plugin.lifecycle), or 0


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived; ``signame`` names it, ``status`` is the exit status (128 + signal)."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        self.signame = "interrupted (Ctrl-C)" if signum == signal.SIGINT else "terminated (SIGTERM)"
        self.status = 128 + int(signum)
        super().__init__(self.signame)


_SUN_PATH_MAX = 107
"""Bytes of an AF_UNIX socket path (Linux's ``sun_path`` holds 108 with the closing NUL)."""
_FORKSERVER_SOCKET = len("/pymp-12345678/listener-12345678")
"""What multiprocessing adds to the temporary folder for the forkserver's socket (Python 3.11)."""


def warm_start_method() -> str:
    """How the workers of ``batch`` and the service's jobs start: ``forkserver`` where its socket fits.

    The forkserver (warm: loadpath imported once) listens on a socket in the temporary folder, which
    the service puts in its cache folder (:func:`loadpath.plugin.service_job.confine`); a deep folder
    makes that path longer than AF_UNIX takes, and the forkserver cannot start.  Workers are then
    spawned (no socket; each imports loadpath itself, about a second more per worker) rather than
    moving the socket elsewhere.
    """
    import tempfile

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return "spawn"
    fits = len(os.fsencode(tempfile.gettempdir())) + _FORKSERVER_SOCKET <= _SUN_PATH_MAX
    return "forkserver" if fits else "spawn"


def raise_if_stopped() -> None:
    """Raise :class:`Interrupted` if a stop signal arrived whose exception was lost (see lifecycle)."""
    if _pending[0]:
        raise Interrupted(_pending[0])


def die_with_parent(parent_pid: int | None = None, poll_s: float = 1.0) -> None:
    """Make this process end when its parent ends (see the module docstring)."""
    parent = os.getppid() if parent_pid is None else parent_pid
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(poll_s)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="loadpath-orphan-check", daemon=True).start()


def worker_init(parent_pid: int | None = None, clean_exit: bool = False) -> None:
    """Initializer of every worker: ignore SIGINT, die with the parent.

    ``clean_exit``: SIGTERM raises ``SystemExit`` so the worker's ``finally`` clauses run (a worker
    that writes files removes its temporary file); otherwise SIGTERM ends it at once.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # a forked worker inherits the parent's handler: reset it
    signal.signal(signal.SIGTERM, _exit_cleanly if clean_exit else signal.SIG_DFL)
    if clean_exit:
        sys.unraisablehook = _stop_raised_in_a_callback
    die_with_parent(parent_pid)


def _exit_cleanly(signum: int, frame: object) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    raise SystemExit(128 + signum)


def _stop_raised_in_a_callback(unraisable: Any) -> None:
    """``sys.unraisablehook`` of a ``clean_exit`` worker: the stop's ``SystemExit`` raised in Python
    code that C called back (numba's compiled-code cache, through llvmlite) cannot leave the
    callback; Python would print it as "Exception ignored ..." with a traceback and go on working.
    The worker asks itself again a moment later instead (from a timer thread: a signal sent here
    would be handled here, still inside the callback), until the handler runs outside one and its
    ``SystemExit`` ends the worker.  Anything else goes to Python's own hook."""
    if isinstance(unraisable.exc_value, SystemExit):
        signal.signal(signal.SIGTERM, _exit_cleanly)
        again = threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGTERM))
        again.daemon = True
        again.start()
        return
    sys.__unraisablehook__(unraisable)


def stop_pool(pool: Any, grace_s: float = 2.0) -> None:
    """Stop a ``ProcessPoolExecutor`` now: cancel what has not started, end its workers (SIGTERM, then
    SIGKILL after ``grace_s``).

    ``shutdown()`` alone waits for every running job to finish (minutes for an engine run); on an
    interrupt or an error the results are not wanted.
    """
    procs = list((getattr(pool, "_processes", None) or {}).values())  # the executor's table of workers
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:  # SIGTERM first: a worker started with clean_exit removes its temporary files
        _signal(p, "terminate")
    deadline = time.monotonic() + grace_s
    for p in procs:
        _join(p, max(0.0, deadline - time.monotonic()))
    for p in procs:
        if _alive(p):
            _signal(p, "kill")
            _join(p, 5.0)
    manager = getattr(pool, "_executor_manager_thread", None)  # sees the dead workers and ends; left
    if manager is not None:  # running, it writes to their closed pipes at interpreter exit
        manager.join(5.0)


def forks(workers: int, n: int) -> bool:
    """Whether :func:`fork_map` runs ``n`` calls in ``workers`` forked processes (else in this one)."""
    return workers > 1 and n > 1 and "fork" in multiprocessing.get_all_start_methods()


def spans(n: int, workers: int, per_worker: int) -> list[tuple[int, int]]:
    """Contiguous index ranges ``[a, z)`` covering ``range(n)``: the batches of a :func:`fork_map`.

    ``per_worker`` batches for each worker when :func:`forks` (one round trip per batch, not per
    item, and still enough batches to even out their costs), else one batch; no empty range.
    """
    k = min(n, per_worker * workers) if forks(workers, n) else 1
    cuts = [round(i * n / max(k, 1)) for i in range(k + 1)]
    return [(a, z) for a, z in zip(cuts[:-1], cuts[1:], strict=True) if z > a]


def fork_map(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    workers: int,
    each: Callable[[int, Any], None] | None = None,
) -> list[Any]:
    """``fn(item)`` for every item, in item order: in forked worker processes when :func:`forks`.

    The workers start through :func:`worker_init` (they die with this process); only the item and
    the result cross between processes, so ``fn`` reads its large inputs from module state set
    before the call (inherited by the fork).  ``each(k, result)`` is called as the result of
    ``items[k]`` arrives (completion order in workers, item order here).  An interrupt or a failed
    call stops the other workers (:func:`stop_pool`) instead of waiting for them, and is raised.
    """
    out: list[Any] = [None] * len(items)
    if not forks(workers, len(items)):
        for k, item in enumerate(items):
            out[k] = fn(item)
            if each:
                each(k, out[k])
        return out
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from loadpath.memory import trim

    trim()  # the workers start with the parent's resident pages: not its freed ones
    ctx = multiprocessing.get_context("fork")
    pool = ProcessPoolExecutor(max_workers=min(workers, len(items)), mp_context=ctx,
                               initializer=worker_init, initargs=(os.getpid(),))
    try:
        futures = {pool.submit(fn, item): k for k, item in enumerate(items)}
        raise_if_stopped()
        for fut in as_completed(futures):
            raise_if_stopped()
            k = futures[fut]
            out[k] = fut.result()
            if each:
                each(k, out[k])
        pool.shutdown(wait=True)  # inside: a signal during the wait stops the pool too
    except BaseException:  # an interrupt or a failed call: stop the others instead of waiting
        stop_pool(pool)
        raise
    return out


def _signal(p: Any, how: str) -> None:
    try:
        getattr(p, how)()
    except (OSError, AttributeError, ValueError):
        pass


def _join(p: Any, timeout: float) -> None:
    try:
        p.join(timeout)
    except (OSError, AttributeError, ValueError, AssertionError):
        pass


def _alive(p: Any) -> bool:
    try:
        return bool(p.is_alive())
    except (OSError, AttributeError, ValueError, AssertionError):
        return False


def children_of(pid: int) -> list[int]:
    """Pids whose parent is ``pid`` (Linux ``/proc``; empty elsewhere), for tests and the orphan check."""
    out = []
    try:
        names = os.listdir("/proc")
    except OSError:
        return out
    for name in names:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as fh:
                fields = fh.read().rsplit(b")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(name))
    return out


class OverLimit(Exception):
    """:func:`in_child`: the child used up its CPU time (``RLIMIT_CPU``) or its wall time and was killed."""

    def __init__(self, cpu_s: float, wall_s: float) -> None:
        self.cpu_s, self.wall_s = cpu_s, wall_s
        super().__init__(f"stopped after {cpu_s:.1f} s CPU, {wall_s:.1f} s wall")


class ChildCrashed(Exception):
    """:func:`in_child`: the child died without an answer (a signal such as SIGSEGV, or out of memory)."""


def in_child(fn: Callable[[], Any], cpu_s: float, wall_s: float) -> Any:
    """``fn()`` in a forked child that is killed after ``cpu_s`` s of CPU time or ``wall_s`` s of wall time.

    For C code that can run for ever and that no signal interrupts (gmsh's mesher): the caller
    gets control back at the limit, and a stop signal (:mod:`loadpath.plugin.lifecycle`) ends the
    wait at once.  The child inherits everything (nothing is pickled on the way in), ignores SIGINT
    (its parent answers Ctrl-C), dies with its parent (``PR_SET_PDEATHSIG``) and has its stdout and
    stderr on ``/dev/null``; only its result (or the exception ``fn`` raised) comes back, pickled
    through a pipe.  The child calls no code but ``fn``'s and leaves by ``os._exit``, so locks other
    threads held at the fork do not matter unless ``fn`` takes them.  Where there is no ``fork``
    (Windows), ``fn()`` runs here, without limits.

    Raises
    ------
    OverLimit
        A limit was reached (the child is dead).
    ChildCrashed
        The child died by a signal or gave no answer.
    Exception
        Whatever ``fn`` raised, re-raised here.
    """
    if not hasattr(os, "fork"):  # pragma: no cover (Windows)
        return fn()
    import pickle

    r, w = os.pipe()  # no flush of sys.stdout first: the child leaves by os._exit, its buffers unwritten
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:  # pragma: no cover (the child; covered through its answers)
        os.close(r)
        _child_answer(fn, w, cpu_s)
    os.close(w)
    try:
        data = _read_until(r, t0 + wall_s)
        status, usage = _wait_child(pid, data is None)
    except BaseException:
        _kill_child(pid)
        raise
    finally:
        os.close(r)
    try:
        ok, value = pickle.loads(data) if data else (None, None)
    except Exception:  # noqa: BLE001 (an answer cut short: the child was killed while writing it)
        ok = None
    if ok is None:
        cpu = usage.ru_utime + usage.ru_stime
        sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else 0
        if data is None or sig == signal.SIGXCPU or (sig == signal.SIGKILL and cpu >= cpu_s):
            raise OverLimit(cpu, time.monotonic() - t0)
        how = f"signal {sig}" if sig else f"exit {os.waitstatus_to_exitcode(status)}"
        raise ChildCrashed(f"the child process ended by {how} without a whole answer")
    if ok:
        return value
    raise value


def _child_answer(fn: Callable[[], Any], w: int, cpu_s: float) -> None:  # pragma: no cover (child)
    """In the forked child of :func:`in_child`: limits, run ``fn``, write the pickled answer, exit."""
    import pickle
    import resource

    code = 0
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        if sys.platform.startswith("linux"):
            import ctypes

            ctypes.CDLL(None).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.dup2(null, 2)
        _limit_cpu(resource, max(1, math.ceil(cpu_s)))
        try:
            answer = (True, fn())
        except Exception as exc:  # noqa: BLE001 (re-raised in the parent)
            answer = (False, exc)
        try:
            data = pickle.dumps(answer, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # noqa: BLE001
            data = pickle.dumps((False, RuntimeError(f"{type(exc).__name__}: {exc}")))
        view = memoryview(data)
        while view:
            view = view[os.write(w, view):]
    except BaseException:  # noqa: BLE001
        code = 1
    finally:
        os._exit(code)


def _limit_cpu(resource: Any, seconds: int) -> None:  # pragma: no cover (child)
    """``RLIMIT_CPU`` of ``seconds`` (SIGXCPU), SIGKILL 2 s later; never above a limit already set
    (a caller's own CPU limit, as the fuzzer's, is inherited and cannot be raised)."""
    _, hard = resource.getrlimit(resource.RLIMIT_CPU)
    cap = hard if hard != resource.RLIM_INFINITY else seconds + 2
    resource.setrlimit(resource.RLIMIT_CPU, (min(seconds, cap), min(seconds + 2, cap)))


def _read_until(fd: int, deadline: float) -> bytes | None:
    """Everything written to pipe ``fd`` until its writer closes it; None at ``deadline``."""
    import select

    chunks = []
    while True:
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            return None
        chunk = os.read(fd, 1 << 20)
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)


def _wait_child(pid: int, kill: bool) -> tuple[int, Any]:
    """Kill the child first if ``kill``; its wait status and resource usage."""
    if kill:
        _kill_child(pid, reap=False)
    _, status, usage = os.wait4(pid, 0)
    return status, usage


def _kill_child(pid: int, reap: bool = True) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
        if reap:
            os.waitpid(pid, 0)
    except (ProcessLookupError, ChildProcessError):
        pass
