"""The processed G-code gets the input's permissions (or the umask default), never mkstemp's 0600."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from loadpath.plugin.job import JobRequest, run_job, write_atomic

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ohs.gcode"


def _mode(p: Path) -> int:
    return stat.S_IMODE(p.stat().st_mode)


@pytest.fixture
def umask_022():
    old = os.umask(0o022)
    yield
    os.umask(old)


@pytest.mark.parametrize("mode", [0o644, 0o640, 0o664])
def test_new_output_takes_the_input_mode(tmp_path, umask_022, mode):
    inp = tmp_path / "part.gcode"
    inp.write_bytes(EXAMPLE.read_bytes())
    inp.chmod(mode)
    out = tmp_path / "part.loadpath.gcode"
    write_atomic(out, b"G1 X1\n", mode_like=inp)
    assert _mode(out) == mode
    assert out.read_bytes() == b"G1 X1\n"
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


@pytest.mark.parametrize(("umask", "expected"), [(0o022, 0o644), (0o027, 0o640), (0o077, 0o600)])
def test_new_file_without_input_follows_the_umask(tmp_path, umask, expected):
    old = os.umask(umask)
    try:
        write_atomic(tmp_path / "new.gcode", b";x\n")
    finally:
        os.umask(old)
    assert _mode(tmp_path / "new.gcode") == expected


def test_rewriting_keeps_the_existing_files_mode(tmp_path, umask_022):
    inp = tmp_path / "part.gcode"
    inp.write_bytes(b";a\n")
    inp.chmod(0o664)
    out = tmp_path / "out.gcode"
    out.write_bytes(b";old\n")
    out.chmod(0o640)
    write_atomic(out, b";new\n", mode_like=inp)
    assert _mode(out) == 0o640
    write_atomic(inp, b";in place\n", mode_like=inp)  # --in-place
    assert _mode(inp) == 0o664 and inp.read_bytes() == b";in place\n"


def test_kept_file_on_failure_has_the_input_mode(tmp_path, umask_022):
    """The real job path: a load case that cannot be read, --on-failure keep copies the input."""
    inp = tmp_path / "ohs.gcode"
    inp.write_bytes(EXAMPLE.read_bytes())
    inp.chmod(0o640)
    case = tmp_path / "bad.toml"
    case.write_text("this is not toml = = \n")
    res = run_job(JobRequest(input=inp, loadcase=case, cli={"on_failure": "keep"}))
    assert res.written and res.error
    assert _mode(res.output) == 0o640
    assert res.output.read_bytes() == inp.read_bytes()
