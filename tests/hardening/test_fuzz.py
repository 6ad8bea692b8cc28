"""Fuzzing in CI (#20), bounded to well under a minute: hypothesis drives the mutators of
``scripts/fuzz.py`` (byte, line and number mutations of every committed real slicer file) and
generates G-code lines of its own, inserted into those files.

Every outcome must be a parsed file or one ``LoadpathError`` line; through the command line (the
script's fork harness: one child per case with a CPU limit, its process group killed after), exit 0
or one ``loadpath:`` line, never an ``internal error``, a hang (30 s) or a changed input.  The
harness itself is checked on deliberately broken commands.  The long run is
``nice -n 10 python scripts/fuzz.py --slice --n 100000`` (see its docstring).
"""

from __future__ import annotations

import functools
import random
from pathlib import Path

from fixtures import load_script
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from loadpath import gcode
from loadpath.errors import LoadpathError


REPO = Path(__file__).resolve().parents[2]


@functools.cache
def _fuzz():
    return load_script(REPO / "scripts" / "fuzz.py", "loadpath_fuzz")


@functools.cache
def _sources() -> tuple[bytes, ...]:
    files = _fuzz().real_files()
    assert len(files) >= 5
    return tuple(f.read_bytes() for f in files)


def _parse_is_clean(data: bytes) -> None:
    try:
        gcode.parse(data)
    except LoadpathError as exc:
        assert "\n" not in str(exc) and str(exc).strip()


def _settings(n: int) -> settings:
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@_settings(120)
@given(seed=st.integers(0, 2**32 - 1), which=st.integers(0, 100), k=st.integers(1, 3))
def test_mutated_real_files_parse_or_refuse_in_one_line(seed, which, k):
    data = _sources()[which % len(_sources())]
    _parse_is_clean(_fuzz().mutate(data, random.Random(seed), k))


_NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(lambda v: repr(v)),
    st.integers(-10**320, 10**320).map(str),
    st.decimals(allow_nan=False, allow_infinity=False, places=3).map(str),
    st.text("0123456789.-+e", min_size=0, max_size=12),
)
_WORD = st.tuples(st.sampled_from("XYZEFIJRST"), _NUMBER).map("".join)
_LINE = st.one_of(
    st.tuples(st.sampled_from(["G0", "G1", "G2", "G3", "G92", "G10", "G11", "M82", "M83", "G90", "G91"]),
              st.lists(_WORD, max_size=5)).map(lambda t: " ".join([t[0], *t[1]])),
    st.tuples(st.sampled_from([";TYPE:", ";WIDTH:", ";HEIGHT:", ";Z:", "; printing object ", ";MESH:",
                               ";LAYER:", "; FEATURE: ", "M486 S"]), _NUMBER).map("".join),
    st.text(max_size=40),
)


@_settings(80)
@given(lines=st.lists(_LINE, min_size=1, max_size=6), which=st.integers(0, 100), where=st.floats(0, 1))
def test_generated_lines_in_real_files_parse_or_refuse_in_one_line(lines, which, where):
    data = _sources()[which % len(_sources())]
    rows = data.split(b"\n")
    at = int(where * (len(rows) - 1))
    rows[at:at] = [ln.encode("utf-8", "surrogatepass") for ln in lines]
    _parse_is_clean(b"\n".join(rows))


@_settings(8)
@given(seed=st.integers(0, 2**32 - 1), which=st.integers(0, 100))
def test_mutated_real_files_through_inspect(tmp_path_factory, seed, which):
    fuzz, sources = _fuzz(), _sources()
    out = tmp_path_factory.mktemp("fuzz")
    path = out / "case.gcode"
    path.write_bytes(fuzz.mutate(sources[which % len(sources)], random.Random(seed)))
    kind, text = fuzz.classify(path, "inspect", out, 30.0)
    assert kind in ("ok", "refused"), f"inspect: {kind}: {text}"


def test_a_mutated_real_file_through_run(tmp_path):
    """One ``run`` (about 20 s): the shipped specimen with three mutations of a fixed seed."""
    fuzz = _fuzz()
    (tmp_path / "case.toml").write_text(fuzz.CASE)
    path = tmp_path / "case.gcode"
    path.write_bytes(fuzz.mutate((REPO / "examples" / "ohs.gcode").read_bytes(), random.Random(20), 3))
    kind, text = fuzz.classify(path, "run", tmp_path, 60.0)
    assert kind in ("ok", "refused"), f"run: {kind}: {text}"


def test_the_fuzz_harness_sees_each_kind_of_finding(tmp_path):
    """The fork harness of ``scripts/fuzz.py`` on deliberately broken commands (a few seconds).

    A bug deep in the real ``inspect`` (the reader replaced by one that divides by zero: the
    catch-all's one ``internal error`` line), an exception escaping ``main``, a refusal of two lines,
    a busy loop past a 1 s CPU limit, a command that rewrites its input and one that leaves a process
    behind must each be classified as that finding, and the real ``inspect`` of the shipped specimen
    as ``ok``; otherwise a long fuzz run reporting zero findings would prove nothing.
    """
    assert _fuzz()._selftest(tmp_path) == []
