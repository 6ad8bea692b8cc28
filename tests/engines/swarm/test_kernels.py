"""The compiled kernels' plumbing: the on-disk cache (reused by new and forked processes, one log
line when cold, stamped with every kernel source) and the hand-written sorts that replace numba's.
"""

import logging
import multiprocessing
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from loadpath.engines.finish import _numba as shared
from loadpath.engines.swarm import _jit as jit
from loadpath.engines.swarm import kernel_step as ks
from loadpath.engines.swarm import warmup


@pytest.fixture(scope="module")
def warm():
    """The kernels compiled (or loaded) in this process, as after ``scripts/setup.sh``."""
    warmup.warm_up()
    return True


def test_stable_argsort_is_numpys_stable_order():
    rng = np.random.default_rng(7)
    for n in [*range(12), 33, 257]:
        for v in (rng.normal(size=n), rng.integers(0, 3, n).astype(float), np.zeros(n)):
            assert np.array_equal(ks._stable_argsort(v), np.argsort(v, kind="stable"))


def test_every_kernel_is_stamped_with_all_kernel_sources():
    # a cached caller holds its callees' machine code: editing any kernel source must recompile all
    # (the shared kernels of loadpath.engines.finish call no swarm code: their own sources suffice;
    # the FEA's point location and the stiffness model's bead sampling are families of their own,
    # the sampling's including the point location it inlines)
    from loadpath import jit as lp_jit
    from loadpath.fea import locate_kernel
    from loadpath.stiffness import sample_kernel  # noqa: F401 - its kernels register on import

    assert len(lp_jit._stamp(jit.SOURCES)) == len(jit.SOURCES) >= 4 and set(shared.SOURCES) < set(jit.SOURCES)
    assert len(lp_jit.FAMILIES) > 20
    swarm_dir, finish_dir = jit.SOURCES[-1].parent, shared.SOURCES[0].parent
    locate = Path(locate_kernel.__file__).resolve()
    seen = set()
    for disp, sources in lp_jit.FAMILIES:
        src = Path(disp.py_func.__code__.co_filename).resolve()
        assert src in sources, disp.py_func.__name__  # its own file at least
        if src.parent == swarm_dir:
            assert sources == jit.SOURCES, disp.py_func.__name__
        elif src.parent == finish_dir:
            assert sources == shared.SOURCES, disp.py_func.__name__
        elif src.name == "sample_kernel.py":
            assert set(sources) == {src, locate}, disp.py_func.__name__
        assert disp._cache._cache_file._source_stamp == lp_jit._stamp(sources), disp.py_func.__name__
        seen.add(src.parent)
    assert {swarm_dir, finish_dir, locate.parent} <= seen


def test_a_new_process_loads_the_kernels_from_the_cache(warm):
    assert warmup.kernels_cached()
    code = (
        "from loadpath.engines.swarm import kernel_step as ks, warmup\n"
        "assert warmup.kernels_cached()\n"
        "warmup.warm_up()\n"
        "st = ks.run_swarm.stats\n"
        "print(sum(st.cache_hits.values()), sum(st.cache_misses.values()))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=os.environ
    )
    hits, misses = map(int, out.stdout.split())
    assert hits >= 1 and misses == 0, out.stdout
    assert "compiling the swarm engine" not in out.stderr


def _compiles(disp) -> tuple[int, int, int]:
    st = disp.stats
    return len(disp.signatures), sum(st.cache_misses.values()), sum(st.cache_hits.values())


def _child_compiles(queue):
    before = _compiles(ks.run_swarm)
    warmup.warm_up()
    queue.put((before, _compiles(ks.run_swarm)))


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs fork")
def test_forked_workers_inherit_the_compiled_kernels(warm):
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_child_compiles, args=(queue,))
    proc.start()
    before, after = queue.get(timeout=120)
    proc.join(timeout=30)
    assert proc.exitcode == 0
    assert before[0] >= 1  # compiled code came with the fork
    assert after == before  # nothing compiled nor loaded again


def test_one_log_line_when_the_kernels_must_be_compiled(monkeypatch, caplog):
    monkeypatch.setattr(jit, "kernels_cached", lambda disp: False)
    monkeypatch.setattr(jit, "_ANNOUNCED", False)
    with caplog.at_level(logging.WARNING, logger="loadpath.engines.swarm"):
        assert not jit.announce_compile(ks.run_swarm)
        assert not jit.announce_compile(ks.run_swarm)
    lines = [r.getMessage() for r in caplog.records if "compiling the swarm engine" in r.getMessage()]
    assert len(lines) == 1, lines


def test_no_log_line_when_cached(warm, caplog):
    with caplog.at_level(logging.WARNING, logger="loadpath.engines.swarm"):
        assert jit.announce_compile(ks.run_swarm)
    assert not caplog.records
