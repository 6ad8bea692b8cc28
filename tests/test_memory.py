"""loadpath.memory.trim gives freed heap pages back: the resident size drops by what was freed."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from loadpath.memory import trim


def _rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise AssertionError("no VmRSS")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc and /proc")
def test_freed_arrays_leave_the_resident_size_after_trim():
    """Arrays of 2 MB freed in the middle of the heap stay resident until trim() returns them (first
    a 16 MB array is freed, which raises glibc's mmap threshold so that 2 MB comes from the heap, as
    a parse's per-line arrays do)."""
    big = np.ones(2_000_000)  # 16 MB, mmapped; freeing it raises the threshold to 16 MB
    del big
    arrays = [np.ones(250_000) for _ in range(200)]  # 400 MB of 2 MB arrays from the heap
    for k in range(0, len(arrays), 2):  # free every other one: holes, not the heap's top
        arrays[k] = None
    before = _rss_mb()
    assert trim()
    after = _rss_mb()
    assert before - after > 100, (before, after)
    assert all(a is None or a[0] == 1.0 for a in arrays)  # what is still held is intact


_UNMAPPED = """
import numpy as np
from loadpath.memory import map_large_arrays

def rss_mb():
    with open("/proc/self/status") as fh:
        return next(int(ln.split()[1]) / 1024 for ln in fh if ln.startswith("VmRSS:"))

assert map_large_arrays()
big = np.ones(2_000_000)
del big
arrays = [np.ones(750_000) for _ in range(60)]  # 360 MB of 6 MB arrays
before = rss_mb()
for k in range(0, len(arrays), 2):
    arrays[k] = None
print(before - rss_mb())
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc and /proc")
def test_large_arrays_are_unmapped_when_freed():
    """After map_large_arrays(), 6 MB arrays freed among held ones leave the resident size at once,
    though a 16 MB array freed first would have raised glibc's threshold above them.

    In a process of its own, as the command line sets it at its start: glibc serves a large block
    from a free chunk of its heap when it has one, and a test worker's heap holds what the tests
    before it freed (CI, 2026-12-07: 109 of the 180 MB freed left, the worker's heap having served
    the rest)."""
    import subprocess

    out = subprocess.run([sys.executable, "-c", _UNMAPPED], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert float(out.stdout) > 120, out.stdout
