"""``loadpath batch``: many real files in parallel processes, and on a local Dask cluster."""

from __future__ import annotations

import io
import shutil
from pathlib import Path

import pytest
from fixtures import without_verdict
from integration_helpers import assert_spliced, reference, write_case
from loadpath.errors import SettingsError
from loadpath.plugin import batch, batch_cluster
from loadpath.plugin.cli import main

ARGS = ["--engine", "streamlines"]


@pytest.fixture(scope="module")
def folder(tmp_path_factory, sliced) -> Path:
    """Two real files (PrusaSlicer bracket, CuraEngine bracket), a broken one and an earlier output."""
    d = tmp_path_factory.mktemp("batch")
    shutil.copy(sliced("prusa", "bracket", "mixed"), d / "bracket.gcode")
    shutil.copy(sliced("cura", "bracket", "mixed"), d / "cura-bracket.gcode")
    (d / "broken.gcode").write_bytes(b"G1 X\x00 garbage\n")
    shutil.copy(sliced("prusa", "bracket", "mixed"), d / "old.loadpath.gcode")  # an earlier output: skipped
    write_case(d)
    return d


def _rows(out: str) -> dict[str, list[str]]:
    return {
        ln.split()[0]: ln.split()[1:5]  # file, status, time, beta, coverage (then warnings, verdict)
        for ln in out.splitlines()[1:]
        if ln.split() and ln.split()[0].endswith(".gcode") and len(ln.split()) >= 7
    }


@pytest.fixture(scope="module")
def local_run(folder):
    """``loadpath batch FOLDER`` with two processes, on the folder's own result cache
    (``folder/cache``, which the cluster test shares); (exit status, stdout)."""
    cap = io.StringIO()
    import contextlib

    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(cap):
        mp.setenv("LOADPATH_CACHE_DIR", str(folder / "cache"))
        status = main(["batch", str(folder), "--loadcase", str(folder / "case.toml"), "--jobs", "2", *ARGS])
    return status, cap.getvalue()


@pytest.mark.slow
def test_batch_processes_every_file_and_reports_the_failure(folder, local_run, tmp_path):
    status, out = local_run
    assert status == 1, out  # one file failed
    rows = _rows(out)
    names = {Path(k).name for k in rows}
    assert names == {"bracket.gcode", "cura-bracket.gcode", "broken.gcode"}  # not the earlier output
    by = {Path(k).name: v for k, v in rows.items()}
    for name in ("bracket.gcode", "cura-bracket.gcode"):
        st, secs, beta, cov = by[name]
        assert st == "ok" and float(secs) > 0
        assert 0.9 <= float(beta) <= 1.0 and 0.9 <= float(cov) <= 1.0  # streamlines follow the field
    assert by["broken.gcode"][0] == "failed" and by["broken.gcode"][2] == "-"
    assert "3 file(s): 2 ok, 0 unchanged, 0 kept, 1 failed" in out
    assert "broken.gcode: line 1: the file is not text" in out
    # outputs named like `loadpath run` without -o, and checked like any splice
    assert (folder / "bracket.loadpath.gcode").is_file() and (
        folder / "cura-bracket.loadpath.gcode"
    ).is_file()
    assert (
        not (folder / "broken.loadpath.gcode").exists()
        and not (folder / "old.loadpath.loadpath.gcode").exists()
    )
    ref = reference(folder / "bracket.gcode", folder / "case.toml", tmp_path / "ref.gcode")
    assert_spliced(folder / "bracket.gcode", (folder / "bracket.loadpath.gcode").read_bytes(), ref)


@pytest.mark.slow
def test_batch_on_a_local_dask_cluster(folder, local_run, tmp_path, capsys, monkeypatch):
    """The cluster's workers share the local run's result cache: what is tested here is the cluster's
    way of sending files and answers (the engines' own determinism is tested elsewhere)."""
    distributed = pytest.importorskip("distributed")
    monkeypatch.setenv("LOADPATH_CACHE_DIR", str(folder / "cache"))
    out_dir = tmp_path / "out"
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as c:
        status = main(
            [
                "batch",
                str(folder / "*.gcode"),
                "--loadcase",
                str(folder / "case.toml"),
                "--out",
                str(out_dir),
                "--no-metrics",
                "--cluster",
                c.scheduler_address,
                *ARGS,
            ]
        )
    out = capsys.readouterr().out
    assert status == 1, out
    assert sorted(p.name for p in out_dir.iterdir()) == ["bracket.gcode", "cura-bracket.gcode"]
    for name in ("bracket", "cura-bracket"):  # what the cluster returned is what the local processes wrote
        assert without_verdict((out_dir / f"{name}.gcode").read_bytes()) == without_verdict(
            (folder / f"{name}.loadpath.gcode").read_bytes()
        )
    assert "broken.gcode: line 1: the file is not text" in out


def test_exit_status_0_when_every_file_succeeds(folder, tmp_path, capsys):
    out_dir = tmp_path / "o"
    status = main(
        [
            "batch",
            str(folder / "bracket.gcode"),
            "--loadcase",
            str(folder / "case.toml"),
            "--out",
            str(out_dir),
            "--no-metrics",
            "--jobs",
            "1",
            *ARGS,
        ]
    )
    out = capsys.readouterr().out
    assert status == 0, out
    assert "1 file(s): 1 ok" in out and (out_dir / "bracket.gcode").is_file()


def test_plan_refuses_collisions_and_overwrites(folder, tmp_path):
    case = folder / "case.toml"
    other = tmp_path / "other"
    other.mkdir()
    shutil.copy(folder / "bracket.gcode", other / "bracket.gcode")
    with pytest.raises(SettingsError, match="would both be written"):
        batch.plan([str(folder / "bracket.gcode"), str(other / "bracket.gcode")], case, tmp_path / "out")
    with pytest.raises(SettingsError, match="would overwrite"):
        batch.plan([str(folder / "bracket.gcode")], case, folder)
    with pytest.raises(SettingsError, match="names no G-code file"):
        batch.plan([str(tmp_path / "*.gcode")], case)
    with pytest.raises(SettingsError, match="does not exist"):
        batch.plan([str(folder)], tmp_path / "nope.toml")
    tasks = batch.plan([str(folder)], case)
    assert [t.output.name for t in tasks] == [
        "bracket.loadpath.gcode",
        "broken.loadpath.gcode",
        "cura-bracket.loadpath.gcode",
    ]
    assert all(t.cli["jobs"] == 1 for t in tasks)


def test_unreachable_scheduler_is_a_one_line_error(folder):
    pytest.importorskip("distributed")
    tasks = batch.plan([str(folder / "bracket.gcode")], folder / "case.toml")
    with pytest.raises(SettingsError, match="cannot reach the Dask scheduler"):
        batch_cluster.run_cluster(tasks, "tcp://127.0.0.1:9", timeout=2)


def test_progress_bar_only_on_a_terminal():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty, pipe = Tty(), io.StringIO()
    for stream in (tty, pipe):
        bar = batch.BatchProgress(stream)
        bar(batch.FileResult("a.gcode", "ok", 1.0), 1, 2)
        bar(batch.FileResult("b.gcode", "failed", 1.0), 2, 2)
        bar.close()
    assert "2/2 files, 1 failed" in tty.getvalue() and tty.getvalue().endswith("\r")
    assert pipe.getvalue() == ""


def test_metrics_summary_weights_by_area_and_layers():
    m = {
        "layers": [
            {"region_area_mm2": 100.0, "layers": [2, 3], "new": {"beta": 0.9, "coverage": 1.0}},
            {"region_area_mm2": 200.0, "layers": [5], "new": {"beta": 0.6, "coverage": 0.5}},
            {"region_area_mm2": 50.0, "layers": [7], "new": {"beta": float("nan"), "coverage": 0.1}},
        ]
    }
    beta, cov = batch.metrics_summary(m)
    assert beta == pytest.approx(0.75) and cov == pytest.approx(0.75)
    assert batch.metrics_summary({"layers": []}) == (None, None)


def test_a_mistyped_set_key_stops_the_batch_before_any_file(folder, tmp_path, capsys):
    out = tmp_path / "out"
    status = main(["batch", str(folder), "--loadcase", str(folder / "case.toml"), "--out", str(out),
                   "--set", "widht_max=1.4"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1 and "did you mean width_max?" in err[0], err
    assert not out.exists()
