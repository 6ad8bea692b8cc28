"""What a run tells about itself: what became of the files, its warnings, its log and its mark.

Used by :func:`loadpath.plugin.job.run_job`: :func:`fate` words every failure message's end,
:func:`own_warnings` turns Python / numpy warnings into one-line warnings of loadpath's,
:func:`log` appends the verdict to ``$XDG_STATE_HOME/loadpath/runs.log``, and
:func:`already_processed` / :func:`with_header` read and write the verdict line in the G-code.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

__all__ = ["fate", "state_folder", "log", "own_warnings", "already_processed", "with_header"]


def fate(inp: Path, out: Path, written: bool) -> str:
    """What became of the input and the output, in words, for a message."""
    if written:
        return f"{str(out)!r} was written" + ("" if out == inp else f"; the input {str(inp)!r} is untouched")
    if out == inp:
        return f"the G-code {str(inp)!r} is untouched"
    return f"the input {str(inp)!r} is untouched and {str(out)!r} was not written"


def state_folder(env: Mapping[str, str] | None = None) -> Path:
    """``$XDG_STATE_HOME/loadpath`` (default ``~/.local/state/loadpath``): where the run log goes."""
    env = os.environ if env is None else env
    base = env.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state")
    return Path(base) / "loadpath"


def log(line: str) -> str | None:
    """Append one line to the run log; a warning when it cannot be written (None when it was)."""
    folder = state_folder()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with open(folder / "runs.log", "a", encoding="utf-8") as fh:
            fh.write(line.rstrip("\n") + "\n")
    except OSError as exc:
        return f"the run log {str(folder / 'runs.log')!r} could not be written ({exc.strerror or exc})"
    return None


def own_warnings(caught: list) -> list[str]:
    """Python / numpy warnings recorded during a run as one-line warnings of ours (each once); clears them.

    No library warning reaches the user's stderr as Python prints it (file, line, source line):
    a numerical warning is a check the code missed, so it says where and asks for a report.
    """
    seen: dict[tuple, str] = {}
    for w in caught:
        key = (w.category.__name__, str(w.message), w.filename, w.lineno)
        where = f"{Path(w.filename).parent.name}/{Path(w.filename).name}:{w.lineno}"
        seen.setdefault(
            key, f"{w.category.__name__} in {where}: {' '.join(str(w.message).split())} (please report this)"
        )
    caught.clear()
    return list(seen.values())


def already_processed(program) -> tuple[str, str] | None:
    """``(version, date)`` when the program's first lines carry loadpath's header comment."""
    from loadpath.verdict import find_header

    head = "\n".join(program.line(i) for i in range(min(program.n_lines, 64)))
    return find_header(head.encode("utf-8", "replace"))


def with_header(data: bytes, line: str) -> bytes:
    """Insert ``line`` as the second line of the G-code text (the slicer's own first line stays first)."""
    nl = b"\r\n" if b"\r\n" in data[:4096] else b"\n"
    i = data.find(b"\n")
    cut = 0 if i < 0 else i + 1
    return data[:cut] + line.encode("utf-8") + nl + data[cut:]
