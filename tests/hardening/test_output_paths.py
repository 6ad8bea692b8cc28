"""Output and input paths (#20): nothing but a regular file or a new path is written; the input is
rewritten only with --in-place, under any spelling; --in-place through a symlink keeps the link.

Before: ``-o FIFO`` and ``-o <device>`` replaced the node with a regular file (as root ``-o /dev/null``
replaced the system's /dev/null), ``-o ./part.gcode`` rewrote the input with exit 0, ``--in-place`` on a
symlink replaced the link with a file, and a folder, FIFO or symlink loop as input was "does not exist"
(a FIFO blocked forever).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import threading

import pytest
from cases import GRIP_PULL
from loadpath.files import check_output, read_regular
from loadpath.plugin.cli import main


@pytest.fixture()
def work(tmp_path, sliced):
    src = sliced("prusa", "ohs", "solid")
    d = tmp_path / "dir"
    d.mkdir()
    g = d / "part.gcode"
    shutil.copyfile(src, g)
    case = tmp_path / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    return d, g, case


def _digest(p) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def _run(capsys, *argv) -> tuple[int, str]:
    code = main(["run", *map(str, argv)])
    return code, capsys.readouterr().err.strip()


def test_output_onto_a_fifo_is_refused_and_never_blocks(work, capsys):
    d, g, case = work
    fifo = d / "out.gcode"
    os.mkfifo(fifo)
    code, err = _run(capsys, g, "--loadcase", case, "-o", fifo)
    assert code == 1 and err.count("\n") == 0
    assert "is a FIFO (named pipe); loadpath writes only regular files" in err
    assert err.endswith(f"the input {str(g)!r} is untouched and {str(fifo)!r} was not written")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert sorted(p.name for p in d.iterdir()) == ["out.gcode", "part.gcode"]


def test_output_onto_a_device_is_refused(work, capsys):
    d, g, case = work
    assert "is a character device" in check_output("/dev/null", g, in_place=False)
    if os.geteuid() == 0:  # a device node of our own: a regression cannot hurt the system's /dev/null
        dev = d / "null"
        os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))
        code, err = _run(capsys, g, "--loadcase", case, "-o", dev)
        assert code == 1 and "is a character device" in err and err.count("\n") == 0
        assert stat.S_ISCHR(os.lstat(dev).st_mode)
    assert "is a folder" in check_output(d, g, in_place=False)


@pytest.mark.parametrize("spelling", ["dot", "absolute", "dotdot", "hardlink", "symlink"])
def test_output_equal_to_the_input_needs_in_place(work, capsys, monkeypatch, spelling):
    d, g, case = work
    before = _digest(g)
    monkeypatch.chdir(d)
    out = {
        "dot": "./part.gcode",
        "absolute": str(g.resolve()),
        "dotdot": f"../{d.name}/part.gcode",
        "hardlink": "hard.gcode",
        "symlink": "soft.gcode",
    }[spelling]
    if spelling == "hardlink":
        os.link(g, d / out)
    if spelling == "symlink":
        os.symlink("part.gcode", d / out)
    code, err = _run(capsys, "part.gcode", "--loadcase", case, "-o", out)
    assert code == 1 and err.count("\n") == 0
    assert "is the input file; pass --in-place" in err and err.endswith("'part.gcode' is untouched")
    assert _digest(g) == before
    assert not [p for p in d.iterdir() if p.name.startswith(".")]


def test_input_that_is_not_a_file_is_named(work, capsys):
    d, g, case = work
    fifo = d / "pipe.gcode"
    os.mkfifo(fifo)
    loop = d / "loop.gcode"
    os.symlink(loop, loop)
    cases = {d: "is a folder", fifo: "is a FIFO (named pipe)", loop: "is a symbolic link loop"}
    for path, what in cases.items():
        result = []
        t = threading.Thread(target=lambda p=path: result.append(_run(capsys, p, "--loadcase", case)),
                             daemon=True)
        t.start()
        t.join(30)
        assert not t.is_alive(), f"run blocked on {what}"
        code, err = result[0]
        assert code == 1 and what in err and "does not exist" not in err and err.count("\n") == 0
    # as load case and for inspect too
    code, err = _run(capsys, g, "--loadcase", fifo)
    assert code == 1 and "is a FIFO" in err
    assert main(["inspect", str(fifo)]) == 1
    assert "is a FIFO" in capsys.readouterr().err
    assert main(["inspect", "/dev/zero"]) == 1
    assert "is a character device" in capsys.readouterr().err
    with pytest.raises(OSError, match="FIFO"):
        read_regular(fifo)


def test_in_place_through_a_symlink_rewrites_the_target_and_keeps_the_link(work, capsys):
    d, g, case = work
    link = d / "link.gcode"
    os.symlink("part.gcode", link)
    before = _digest(g)
    code, err = _run(capsys, link, "--loadcase", case, "--in-place", "--engine", "streamlines")
    assert code == 0, err
    assert link.is_symlink() and os.readlink(link) == "part.gcode"
    assert _digest(g) != before
    assert sorted(p.name for p in d.iterdir()) == ["link.gcode", "part.gcode"]


def test_output_into_a_missing_folder_says_what_became_of_the_files(work, capsys):
    d, g, case = work
    out = d / "nodir" / "x.gcode"
    code, err = _run(capsys, g, "--loadcase", case, "-o", out)
    assert code == 1 and err.count("\n") == 0
    assert f"the folder of {str(out)!r} does not exist; create it or choose another output" in err
    assert err.endswith(f"the input {str(g)!r} is untouched and {str(out)!r} was not written")
    assert not (d / "nodir").exists()
