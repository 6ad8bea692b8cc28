"""How a command ends when it is stopped: SIGINT and SIGTERM alike, one line, nothing half-written.

:func:`terminate_as_interrupt` turns SIGINT (Ctrl-C) and SIGTERM into :class:`Interrupted` (a
``KeyboardInterrupt``, so every ``except KeyboardInterrupt`` / ``finally`` clean-up runs: temporary
files are removed by :func:`loadpath.plugin.job.write_atomic`, pools are stopped by
:func:`loadpath.procs.stop_pool`).  :func:`record_writes` collects the files written meanwhile, so
the last line can say what was and was not written (``batch`` interrupted after two files said "no
file was written").
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

from loadpath.procs import Interrupted, _pending, raise_if_stopped

__all__ = ["Interrupted", "raise_if_stopped", "terminate_as_interrupt", "record_writes", "note_written", "what_was_written"]

_sinks: list[list[Path]] = []


_owner = [0]  # pid of the process that installed the handlers


def _raise(signum: int, frame: object) -> None:
    if os.getpid() != _owner[0]:  # a forked worker before its initializer reset the handlers
        if signum == signal.SIGINT:
            return  # its parent stops it
        os._exit(128 + signum)
    # remembered as well as raised: Python drops an exception raised inside an at-fork hook (the
    # paths stage forks its workers), so the stages also check stop_requested() between steps
    _pending[0] = signum
    raise Interrupted(signum)


@contextlib.contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """SIGINT and SIGTERM raise :class:`Interrupted` in the main thread while inside."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    _owner[0] = os.getpid()
    _pending[0] = 0
    for s in old:
        signal.signal(s, _raise)
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)


@contextlib.contextmanager
def record_writes(sink: list[Path]) -> Iterator[list[Path]]:
    """Collect into ``sink`` every file :func:`note_written` reports while inside."""
    _sinks.append(sink)
    try:
        yield sink
    finally:
        _sinks.remove(sink)


def note_written(path: str | os.PathLike) -> None:
    """A file was written completely (called by the atomic write after its rename)."""
    for sink in _sinks:
        sink.append(Path(path))


def what_was_written(written: list[Path]) -> str:
    """'no file was written' / 'wrote a.gcode; nothing else was written' / 'wrote 3 files (a, b, c) ...'."""
    written = list(dict.fromkeys(Path(p) for p in written))  # a file noted by a worker and its parent
    if not written:
        return "no file was written"
    names = ", ".join(str(p) for p in written[:5]) + (f" and {len(written) - 5} more" if len(written) > 5 else "")
    return f"wrote {names}; nothing else was written"
