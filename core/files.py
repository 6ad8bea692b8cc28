"""The user's files: read only regular files (never block on a FIFO), write only where a file may go.

One owner for what every front end and reader needs to know about a path before touching it:

- :func:`read_regular` opens with ``O_NONBLOCK`` and checks ``fstat`` before reading, so a FIFO, a
  device (``/dev/zero``), a folder or a symlink loop is named in one line instead of blocking forever,
  exhausting memory or being called missing; files larger than ``limit`` bytes are refused before they
  are read.
- :func:`check_output` refuses an output path that exists and is not a regular file (``-o /dev/null``
  would otherwise replace the device node with a file), and an output that is the input under another
  spelling (``./part.gcode``, ``../dir/part.gcode``, a hard link: same ``st_dev``/``st_ino``) unless
  the caller rewrites in place.
- :func:`write_target` is where an atomic write must rename to: the target of a symlink, so that
  ``--in-place`` through a link rewrites the file and keeps the link.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

__all__ = ["kind_of", "read_regular", "check_output", "same_file", "write_target", "NotRegularError"]

MAX_READ_BYTES = 2 << 30
"""Largest file read (2 GiB): G-code of the largest printers is a few hundred MB."""


class NotRegularError(OSError):
    """The path is not a regular file; ``str()`` is the one-line reason (what it is)."""


def kind_of(path: str | os.PathLike) -> str | None:
    """What a non-regular path is ('a folder', 'a FIFO (named pipe)', ...); None for a regular file.

    Follows symlinks; a dangling link, a symlink loop and a missing path are named too.
    """
    p = os.fspath(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        return "a dangling symbolic link" if os.path.islink(p) else "missing"
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "a symbolic link loop"
        if exc.errno == errno.ENAMETOOLONG:
            return "a path too long for the system"
        if exc.errno == errno.ENOTDIR:
            return "missing (a part of its path is a file, not a folder)"
        return f"unreadable ({exc.strerror})"
    return _mode_kind(st.st_mode)


def _mode_kind(mode: int) -> str | None:
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def read_regular(path: str | os.PathLike, limit: int = MAX_READ_BYTES) -> bytes:
    """The bytes of a regular file.

    Raises
    ------
    FileNotFoundError
        The path does not exist.
    NotRegularError
        It exists but is no regular file, or is larger than ``limit``; the message says what it is.
    OSError
        It cannot be read (permissions, I/O).
    """
    p = os.fspath(path)
    kind = kind_of(p)
    if kind == "missing":
        raise FileNotFoundError(errno.ENOENT, "No such file or directory", p)
    if kind is not None:
        raise NotRegularError(f"is {kind}, not a file")
    fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    try:
        st = os.fstat(fd)  # the file opened, not the name stat'ed a moment ago
        kind = _mode_kind(st.st_mode)
        if kind is not None:
            raise NotRegularError(f"is {kind}, not a file")
        if st.st_size > limit:
            raise NotRegularError(f"is {st.st_size / 2**30:.1f} GiB, more than any G-code or load case "
                                  f"({limit / 2**30:.0f} GiB at most)")
        with os.fdopen(fd, "rb", closefd=True) as fh:
            fd = -1
            return fh.read()
    finally:
        if fd >= 0:
            os.close(fd)


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Both paths name one file (resolved paths, hard links); False when either does not exist."""
    try:
        sa, sb = os.stat(a), os.stat(b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)
    return (sa.st_dev, sa.st_ino) == (sb.st_dev, sb.st_ino)


def write_target(path: str | os.PathLike) -> Path:
    """Where to write ``path``: the file a symlink points to (resolved), else the path itself."""
    p = Path(path)
    return Path(os.path.realpath(p)) if p.is_symlink() else p


def check_output(out: str | os.PathLike, inp: str | os.PathLike | None, in_place: bool) -> str | None:
    """Why ``out`` may not be written (one line), or None.

    ``out`` may be a new path or an existing regular file (through a symlink: its target); the input
    itself only when ``in_place``.
    """
    kind = kind_of(out)
    if kind == "missing" or kind == "a dangling symbolic link":
        return None if os.path.isdir(os.path.dirname(os.path.abspath(out)) or ".") else (
            f"the folder of {os.fspath(out)!r} does not exist; create it or choose another output")
    if kind is not None:
        return f"{os.fspath(out)!r} is {kind}; loadpath writes only regular files: choose a file name"
    if inp is not None and not in_place and same_file(out, inp):
        return (f"the output {os.fspath(out)!r} is the input file; pass --in-place to rewrite the input, "
                "or choose another output")
    return None
