"""``loadpath run`` and ``loadpath demo`` as a user meets them: exit status, files, stderr (interface.md)."""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import pytest
from cases import GRIP_PULL
from loadpath import gcode
from loadpath.plugin.cli import main

REPO = Path(__file__).resolve().parents[2]
CASE = GRIP_PULL


@pytest.fixture()
def work(tmp_path, sliced):
    """A folder with the specimen (PrusaSlicer, 100 % infill) and a load case."""
    src = sliced("prusa", "ohs", "solid")
    g = tmp_path / "part.gcode"
    shutil.copyfile(src, g)
    case = tmp_path / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    return tmp_path, g, case


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_run_writes_next_to_the_input_and_leaves_it_untouched(work, capsys):
    folder, g, case = work
    before = g.read_bytes()
    assert main(["run", str(g), "--loadcase", str(case), "--engine", "streamlines"]) == 0
    out = folder / "part.loadpath.gcode"
    assert out.is_file() and g.read_bytes() == before
    program, result = gcode.read(g), gcode.read(out)
    assert result.dialect == program.dialect and len(result.layers) == len(program.layers)
    assert out.read_bytes() != before
    err = capsys.readouterr().err
    assert "\r" not in err  # no progress bar when stderr is not a terminal
    assert _leftovers(folder) == []


@pytest.mark.slow
def test_run_output_and_report(work):
    folder, g, case = work
    out = folder / "sub" / "x.gcode"
    out.parent.mkdir()
    rep = folder / "report"
    assert (
        main(
            [
                "run",
                str(g),
                "--loadcase",
                str(case),
                "--engine",
                "streamlines",
                "-o",
                str(out),
                "--report",
                str(rep),
            ]
        )
        == 0
    )
    assert out.is_file()
    html = (rep / "index.html").read_text(encoding="utf-8")
    assert "<svg" in html and "alignment" in html
    data = json.loads((rep / "metrics.json").read_text(encoding="utf-8"))
    assert data["changed"] and data["layers"]
    layer = data["layers"][0]
    for key in ("beta", "spacing_var", "coverage", "overlap"):
        assert layer["new"][key] is not None and layer["old"][key] is not None
    assert layer["new"]["beta"] > layer["old"]["beta"]  # the point of it all
    assert layer["volume_new_mm3"] == pytest.approx(layer["volume_old_mm3"], rel=0.03)
    # the report is made before the output is written (a failure of it costs nothing on disk): its
    # times end with the verdict's stiffness prediction
    assert set(data["times_s"]) >= {"parse", "geometry", "fea", "paths", "splice", "check", "verdict"}
    assert (rep / "layer-1.svg").is_file() and (rep / "layer-1-detail.svg").is_file()


def test_in_place_is_atomic(work):
    folder, g, case = work
    before = g.read_bytes()
    assert main(["run", str(g), "--loadcase", str(case), "--engine", "streamlines", "--in-place"]) == 0
    assert g.read_bytes() != before
    assert not (folder / "part.loadpath.gcode").exists()
    assert _leftovers(folder) == []
    gcode.read(g)


def test_failure_is_one_line_and_leaves_everything_untouched(work, capsys):
    folder, g, case = work
    before = g.read_bytes()
    bad = folder / "bad.toml"
    bad.write_text(CASE.replace('side = "x_max", within = 10.0', "x_min = 500.0"), encoding="utf-8")
    assert main(["run", str(g), "--loadcase", str(bad), "--in-place"]) == 1
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("loadpath: ") and "selects no boundary" in lines[0]
    assert g.read_bytes() == before
    assert _leftovers(folder) == [] and not (folder / "part.loadpath.gcode").exists()


def test_on_failure_keep_exits_zero_with_a_warning(work, capsys):
    folder, g, case = work
    before = g.read_bytes()
    bad = folder / "bad.toml"
    bad.write_text("version = 1\n", encoding="utf-8")
    out = folder / "out.gcode"
    assert main(["run", str(g), "--loadcase", str(bad), "-o", str(out), "--on-failure", "keep"]) == 0
    err = capsys.readouterr().err
    assert "warning" in err and "kept the slicer's G-code" in err
    assert g.read_bytes() == before and out.read_bytes() == before


@pytest.mark.parametrize(
    "args,match",
    [
        (["--set", "nonsense=1"], "unknown"),
        (["--pitch", "-1"], "pitch"),
        (["--replace", "walls"], "walls"),
    ],
)
def test_bad_options_are_one_line(work, capsys, args, match):
    folder, g, case = work
    assert main(["run", str(g), "--loadcase", str(case), *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and match in err[0]


def test_missing_input_is_one_line(tmp_path, capsys):
    case = tmp_path / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    assert main(["run", str(tmp_path / "nope.gcode"), "--loadcase", str(case)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not exist" in err[0]


def test_cura_settings_json_drive_travel_and_retraction(tmp_path, sliced):
    """--slicer-settings: what the Cura plugin passes (Cura's own keys) sets the new travels."""
    g = sliced("cura", "ohs", "solid")
    case = tmp_path / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    js = tmp_path / "cura.json"
    js.write_text(
        json.dumps(
            {
                "global": {"speed_travel": 150, "retraction_combing": "off"},
                "extruders": [
                    {
                        "retraction_amount": 1.5,
                        "retraction_retract_speed": 30,
                        "retraction_prime_speed": 20,
                        "material_diameter": 1.75,
                        "retraction_min_travel": 0.5,
                        "machine_nozzle_size": 0.4,
                    }
                ],
            }
        )
    )
    out = tmp_path / "out.gcode"
    assert (
        main(
            [
                "run",
                str(g),
                "--loadcase",
                str(case),
                "--engine",
                "streamlines",
                "-o",
                str(out),
                "--slicer-settings",
                str(js),
            ]
        )
        == 0
    )
    text = out.read_text()
    assert "G0 F9000 X" in text  # 150 mm/s travels
    program = gcode.read(out)
    r = program.moves[program.moves["retract"]]
    assert (abs(r["e"] + 1.5) < 1e-4).any() and (r["f"] == 1800).any()


@pytest.mark.slow
def test_demo_writes_result_and_report(tmp_path, monkeypatch, capsys):
    """`loadpath demo` (the README's first command): the shipped example end to end, default engine."""
    monkeypatch.chdir(tmp_path)
    assert main(["demo"]) == 0
    out = tmp_path / "loadpath-demo"
    assert (out / "ohs.loadpath.gcode").is_file()
    assert (out / "report" / "index.html").is_file()
    data = json.loads((out / "report" / "metrics.json").read_text())
    assert data["settings"]["engine"] == "swarm" and data["changed"]
    printed = capsys.readouterr().out
    assert "loadpath demo" in printed
    # no engine named: the example is pulled (no neutral axis cuts its layers), so the level sets
    # lay its solid infill, and the summary names them rather than the setting's swarm
    assert "with levelset paths" in printed
    assert os.path.getsize(out / "ohs.loadpath.gcode") > 100_000


class _Tty(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self):
        return True


def test_progress_bar_only_on_a_terminal():
    from loadpath.plugin.commands.run import Progress

    tty, pipe = _Tty(), io.StringIO()
    for stream in (tty, pipe):
        bar = Progress(stream)
        bar("fea", 0, 1)
        bar("paths", 3, 8)
        bar.close()
    assert "\r" in tty.getvalue() and "paths" in tty.getvalue() and "3/8" in tty.getvalue()
    assert pipe.getvalue() == ""


def test_progress_bar_names_the_layout_after_the_first():
    """A run that lays several layouts (``density = "auto"``, the solid choice) numbers them from the
    second, so the bar does not seem to start over; a shorter line leaves no tail of a longer one."""
    from loadpath.plugin.commands.run import Progress

    stream = _Tty()
    bar = Progress(stream)
    bar("layout", 1, 0)
    bar("paths", 2, 4)
    first = stream.getvalue()
    assert "layout" not in first and "paths" in first
    bar("layout", 2, 0)
    assert stream.getvalue() == first  # the layout event itself draws nothing
    bar("splice", 1, 3)
    second = stream.getvalue()[len(first):]
    assert "layout 2: writing G-code" in second
    bar("fea", 0, 1)
    third = stream.getvalue()[len(first) + len(second):]
    assert len(third) >= len(second)  # padded over the longer line before it


def test_run_job_numbers_each_layout_it_lays(tmp_path, sliced):
    """``run_job`` tells its progress the layouts it lays: ``density = "auto"`` on sparse infill lays
    two candidates (real PrusaSlicer slice)."""
    from loadpath.plugin.job import JobRequest, run_job

    case = tmp_path / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    heard: list[tuple[str, int, int]] = []
    res = run_job(
        JobRequest(sliced("prusa", "ohs", "mixed"), case, output=tmp_path / "out.gcode",
                   cli={"replace": ("solid", "sparse"), "cache": False}),
        progress=lambda stage, done, total: heard.append((stage, done, total)),
    )
    assert res.written and res.density is not None
    layouts = [done for stage, done, _ in heard if stage == "layout"]
    assert layouts == list(range(1, len(layouts) + 1)) and len(layouts) >= 2
    # every layout's stages follow its number
    starts = [i for i, h in enumerate(heard) if h[0] == "layout"]
    assert starts[0] == 0 and all(heard[i + 1][0] != "layout" for i in starts)


def test_run_without_the_check(work, capsys):
    """``--set check=false`` skips the re-read: the run writes its output (it crashed on the counts the
    check's side process makes)."""
    folder, g, case = work
    assert main(["run", str(g), "--loadcase", str(case), "--set", "check=false", "--no-cache"]) == 0
    assert (folder / "part.loadpath.gcode").is_file()
    assert "internal error" not in capsys.readouterr().err


def test_a_block_kept_for_the_pitch_asked_for_blames_the_pitch(tmp_path, sliced, capsys):
    """``--pitch 1`` on 0.45 mm solid infill lays 61 % of the slicer's plastic: the block is kept, and
    the reason named the pitch asked for, not "the engine covered too little of the region"."""
    case = tmp_path / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    src = sliced("prusa", "ohs", "mixed")
    out = tmp_path / "out.gcode"
    assert main(["run", str(src), "--loadcase", str(case), "-o", str(out), "--pitch", "1", "--no-cache"]) == 0
    err = capsys.readouterr().err
    assert "at the pitch asked for (1 mm; unset, the slicer's pitch lays the slicer's plastic)" in err
    assert "the engine covered" not in err
    # --pitch 40 on a 36 mm wide specimen: no path fits at all, and the reason names that pitch too
    at40 = ["--pitch", "40", "--no-cache"]
    assert main(["run", str(src), "--loadcase", str(case), "-o", str(out), *at40]) == 0
    err = capsys.readouterr().err
    assert "no new path fits in" in err and "at the pitch asked for (40 mm)" in err, err


def test_a_load_on_the_support_is_named_as_such(work, capsys):
    """Clamp and pull on the same side: no load reaches the free part of the mesh; the message says
    why it can be so and where to look, in one line."""
    from cases import side_case

    folder, g, case = work
    case.write_text(side_case((1000.0, 0.0, 0.0), loaded="x_min"), encoding="utf-8")
    assert main(["run", str(g), "--loadcase", str(case), "--no-cache"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "do a load and a support select the same edge?" in err
    assert "[[loads]] and [[supports]]" in err and "is untouched" in err


def test_on_a_terminal_the_verdict_is_the_last_line(work, monkeypatch):
    """interface.md: every run ends with its verdict line; on a terminal "wrote OUT" came after it."""
    import io
    import sys

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    folder, g, case = work
    err = Tty()
    monkeypatch.setattr(sys, "stderr", err)
    assert main(["run", str(g), "--loadcase", str(case), "--engine", "streamlines", "--no-cache"]) == 0
    lines = [ln for ln in err.getvalue().replace("\r", "\n").splitlines() if ln.strip()]
    assert lines[-1].startswith("loadpath 0.") and any(ln.startswith("loadpath: wrote ") for ln in lines[:-1])
