"""The Cura plugin's Modify G-Code script, run by Cura 4.13's own code on Cura's own Python.

``cura_driver.py`` runs under Debian's ``/usr/bin/python3`` (the interpreter Debian's Cura uses:
no loadpath, shapely 1.8): Cura's real ``PostProcessingPlugin.loadScripts`` finds and loads the
script from the plugin's ``scripts/`` folder, Uranium's real ``DefinitionContainer`` reads its
settings, and the script (a subclass of the real ``Script``, overriding only
``getSettingValueByKey`` and where Cura's stacks come from) processes real CuraEngine 4.13 output
split into chunks the way Cura does.  The result is checked with the splicer's checks.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from conftest import require_tool
from fixtures import load_script
from integration_helpers import (
    FAST,
    VENV_BIN,
    assert_spliced,
    cura_chunks,
    cura_engine_settings,
    reference,
    write_bad_case,
    write_case,
)
from loadpath.plugin.settings import cura_setting_definitions

HERE = Path(__file__).resolve().parent
SCRIPTS = HERE.parents[1] / "cura_plugin" / "LoadpathInfill" / "scripts"
SEP = ";LOADPATH_CHUNK_SEPARATOR\n"
PROCESSED = ";LOADPATH_PROCESSED\n"


def run_script(tmp: Path, chunks: list[str], values: dict, stacks: dict | None = None) -> dict:
    """Run the script in Cura's Python through ``cura_driver.py``; returns the driver's JSON."""
    require_tool("cura")
    job = {
        "chunks": chunks,
        "values": values,
        "stacks": stacks,
        "scripts_dir": str(SCRIPTS),
        "report_root": str(tmp / "reports"),
        "out": str(tmp / "result.json"),
    }
    (tmp / "job.json").write_text(json.dumps(job), encoding="utf-8")
    proc = subprocess.run(
        ["/usr/bin/python3", str(HERE / "cura_driver.py"), str(tmp / "job.json")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads((tmp / "result.json").read_text(encoding="utf-8"))


def run_extension(tmp: Path, job: dict, timeout: float = 600, **env) -> dict:
    """Drive the plugin loaded as Uranium loads it (``cura_extension_driver.py``, Cura's Python) with
    HOME (where Cura's cache folder, the last report, goes) in ``tmp``; returns the driver's JSON."""
    require_tool("cura")
    (tmp / "home").mkdir()
    job = {"plugin_dir": str(SCRIPTS.parent), "out": str(tmp / "r.json"), **job}
    (tmp / "job.json").write_text(json.dumps(job), encoding="utf-8")
    proc = subprocess.run(
        ["/usr/bin/python3", str(HERE / "cura_extension_driver.py"), str(tmp / "job.json")],
        capture_output=True,
        text=True,
        timeout=timeout,
        env={"PATH": "/usr/bin:/bin", "HOME": str(tmp / "home"), **env},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads((tmp / "r.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def cura_file(sliced) -> Path:
    require_tool("cura")
    return sliced("cura", "ohs", "mixed")


@pytest.mark.real_tool("cura")
@pytest.mark.slow
def test_script_replaces_infill_in_curas_chunks_with_curas_settings(cura_file, tmp_path):
    chunks = cura_chunks(cura_file.read_text(encoding="utf-8"))
    assert chunks[0].startswith(";FLAVOR:") and chunks[2].startswith(";LAYER:0") and len(chunks) == 13
    stacks = cura_engine_settings(cura_file.with_suffix(".stderr.txt").read_text(encoding="utf-8"))
    case = write_case(tmp_path)
    res = run_script(
        tmp_path,
        chunks,
        {"loadcase": str(case), "loadpath_command": str(VENV_BIN / "loadpath"), "engine": "streamlines"},
        stacks,
    )
    new = res["chunks"]
    assert not new[0].startswith(";LOADPATH FAILED"), new[0][:300]
    # the same chunks come back: header first, then one per layer with its own marker, end G-code last
    assert len(new) == len(chunks)
    assert new[0].endswith(PROCESSED)
    assert [ln for ln in new[0].splitlines(True) if not ln.startswith((";loadpath: ", "; loadpath: "))] == (
        chunks[0] + PROCESSED
    ).splitlines(True)  # the header, with loadpath's notes on the estimates and its verdict line
    assert sum(ln.startswith("; loadpath: loadpath ") for ln in new[0].splitlines()) == 1
    assert new[1] == chunks[1]
    assert [c.split("\n", 1)[0] for c in new[2:-1]] == [c.split("\n", 1)[0] for c in chunks[2:-1]]
    assert sum(a != b for a, b in zip(new, chunks, strict=True)) >= 2  # some layers were rewritten

    # the settings read from Cura's stacks reached loadpath
    cura_settings = res["cura_settings"]
    assert cura_settings["extruders"][0]["material_diameter"] == 1.75
    assert cura_settings["global"]["retraction_amount"] == pytest.approx(
        float(stacks["global"]["retraction_amount"])
    )
    metrics = json.loads((tmp_path / "reports" / "last-report" / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["settings_sources"]["retract_length"] == "Cura settings"
    assert metrics["settings_sources"]["filament_diameter"] == "Cura settings"
    assert metrics["settings"]["engine"] == "streamlines"

    # the splicer's checks on what the script returned, against the same run in-process
    joined = tmp_path / "joined.gcode"
    joined.write_text(SEP.join(chunks), encoding="utf-8")
    js = tmp_path / "cura_settings.json"
    js.write_text(json.dumps(cura_settings), encoding="utf-8")
    ref = reference(joined, case, tmp_path / "ref.gcode", slicer_settings=js)
    out = SEP.join([new[0].replace(PROCESSED, ""), *new[1:]]).encode()
    assert_spliced(joined, out, ref)


@pytest.mark.real_tool("cura")
def test_failures_reach_the_user_and_keep_the_gcode(cura_file, tmp_path):
    """Cura swallows script exceptions: the script says what failed at the top of the G-code."""
    chunks = cura_chunks(cura_file.read_text(encoding="utf-8"))
    exe = str(VENV_BIN / "loadpath")
    cases = [
        ({"loadcase": str(write_bad_case(tmp_path)), "loadpath_command": exe}, "[[loads]]"),
        ({"loadcase": str(tmp_path / "missing.toml"), "loadpath_command": exe}, "does not exist"),
        (
            {"loadcase": str(write_case(tmp_path)), "loadpath_command": str(tmp_path / "nope")},
            "loadpath command",
        ),
    ]
    for k, (values, words) in enumerate(cases):
        folder = tmp_path / str(k)
        folder.mkdir()
        res = run_script(folder, chunks, values)
        new = res["chunks"]
        first, rest = new[0].split("\n", 1)
        assert first.startswith(";LOADPATH FAILED: ") and words in first, first
        assert rest == chunks[0] and new[1:] == chunks[1:]


@pytest.mark.real_tool("cura")
def test_script_settings_are_loadpaths_schema_as_uranium_reads_them(tmp_path):
    """getSettingDataString is generated from loadpath's settings schema (no second copy)."""
    res = run_script(tmp_path, [";FLAVOR:Marlin\n"], {"loadcase": ""})
    assert res["labels"] == {"LoadpathScript": "Loadpath stress-aligned infill"}
    defs = res["definitions"]
    schema = cura_setting_definitions(("toolpath",))
    for key, spec in schema.items():
        assert defs[key]["type"] == spec["type"]
        assert defs[key]["default_value"] == (
            spec["default_value"] if spec["type"] != "float" else pytest.approx(spec["default_value"])
        )
    assert list(defs)[:5] == ["loadcase", "loadpath_command", "service_url", "timeout", "report"]
    assert set(defs) - set(schema) == {"loadcase", "loadpath_command", "service_url", "timeout", "report"}
    assert res["chunks"][0].startswith(";LOADPATH FAILED: no load case chosen")


def test_fast_settings_match_the_plugin_defaults():
    """The reference runs differ from the plugin's only in what the tests pass on purpose."""
    assert set(FAST) <= {f for f in cura_setting_definitions(("toolpath", "run"))}


@pytest.mark.real_tool("cura")
@pytest.mark.slow
def test_extensions_menu_processes_on_save_and_shows_the_report(sliced, tmp_path):
    """The plugin loaded as Uranium loads it (plugin.json read by Uranium, SDK checked against Cura
    4.13's), its menu's preferences set, then a save: the chunks are processed once."""
    require_tool("cura")
    chunks = cura_chunks(sliced("cura", "bracket", "mixed").read_text(encoding="utf-8"))
    prefs = {
        "loadcase": str(write_case(tmp_path)),
        "command": str(VENV_BIN / "loadpath"),
        "options": json.dumps({"engine": "streamlines", "pitch": 0.0}),
        "on_save": True,
        "timeout": 300,
    }
    res = run_extension(tmp_path, {"chunks": chunks, "preferences": prefs})
    assert res["compatible"] and res["sdk"] == "7.9.0" and res["qt"] == "PyQt5.QtCore"
    assert res["menu"] == "Loadpath infill" and "Show last report" in res["items"] and len(res["items"]) == 6
    assert res["plugin_dir_searched"]  # so Modify G-Code finds scripts/LoadpathScript.py
    new = res["chunks"]
    assert res["saved_message"].startswith("Stress-aligned infill written"), res["saved_message"]
    verdict = res["saved_message"].splitlines()[1]  # the run's verdict, as loadpath printed it
    assert verdict.startswith("loadpath ") and "replaced" in verdict and ", failure load " in verdict
    assert len(new) == len(chunks) and new != chunks and new[0].endswith(PROCESSED)
    assert res["again"] == new  # a list already processed is left alone
    assert "infill replaced" in res["report_message"] and "beta" in res["report_message"], res[
        "report_message"
    ]


def _edit_from_cura(tmp_path, chunks, mesh=None):
    """Extensions > Loadpath infill > Edit load case... in the plugin loaded as Uranium loads it;
    returns the editor's /api/start answer and the driver's result, and stops the editor."""
    import os
    import re
    import signal
    import time
    import urllib.request

    res = run_extension(
        tmp_path, {"chunks": chunks, "mesh": mesh, "edit": True, "preferences": {"command": str(VENV_BIN / "loadpath")}},
        timeout=300,
    )
    home = tmp_path / "home"
    assert res["pid"], res["message"]
    try:
        (log,) = [q for q in home.rglob("editor.log") if q.parent.parts[-2:] == ("loadpath", "edit")]
        deadline = time.monotonic() + 120
        url = None
        while url is None and time.monotonic() < deadline:
            m = re.search(r"editor at (http://127\.0\.0\.1:\d+/)", Path(log).read_text(encoding="utf-8"))
            url = m.group(1) if m else time.sleep(0.2)
        assert url, Path(log).read_text(encoding="utf-8")
        with urllib.request.urlopen(url + "api/start", timeout=30) as r:
            start = json.loads(r.read())
    finally:
        os.killpg(res["pid"], signal.SIGTERM)  # the editor this test started (its own session)
    return res, start


def test_edit_load_case_hands_the_last_gcode_to_loadpath_edit(sliced, tmp_path):
    require_tool("cura")
    chunks = cura_chunks(sliced("cura", "bracket", "mixed").read_text(encoding="utf-8"))
    res, start = _edit_from_cura(tmp_path, chunks)
    assert "Edit load case..." in res["items"]
    assert "opens in your browser on the last G-code" in res["message"]
    assert start["part"]["kind"] == "gcode" and start["part"]["name"] == "plate.gcode"
    assert start["save_path"] == res["loadcase"] and res["loadcase"].endswith("loadcase.toml")
    assert sum(len(o["holes"]) for o in start["part"]["layers"][0]["objects"]) == 1  # the bracket's bolt hole


def test_edit_load_case_before_slicing_hands_the_plates_meshes_as_stl(test_stls, tmp_path):
    require_tool("cura")
    import trimesh

    (stl,) = test_stls("bracket")
    m = trimesh.load(stl, force="mesh")
    v = m.vertices[:, [0, 2, 1]] * [1.0, 1.0, -1.0]  # slicer axes (z up) -> Cura's scene axes (y up)
    res, start = _edit_from_cura(tmp_path, [], {"vertices": v.tolist(), "faces": m.faces.tolist()})
    assert "the plate's meshes (STL, frame = part)" in res["message"]
    assert start["part"]["kind"] == "stl" and start["frame"] == "part"
    b = start["part"]["bounds"]
    assert b[2] - b[0] == pytest.approx(60.0, abs=1e-3) and b[3] - b[1] == pytest.approx(40.0, abs=1e-3)
    assert sum(len(o["holes"]) for o in start["part"]["layers"][0]["objects"]) == 1


# ------------------------------------------------------------------------------ forced failures

FAULTHOOK = HERE / "faulthook"  # sitecustomize.py: fails one stage inside the loadpath child process
STAGES = ("splice", "check", "rename", "metrics", "report_files")


@pytest.fixture(scope="module")
def faults(tmp_path_factory):
    """A result cache shared by the stages (the analysis and paths are made once) and the fault file."""
    root = tmp_path_factory.mktemp("cura-faults")
    (root / "cache").mkdir()
    return root


@pytest.mark.real_tool("cura")
@pytest.mark.parametrize("stage", STAGES)
def test_a_forced_failure_at_each_stage_is_what_curas_message_says(cura_file, faults, tmp_path, stage):
    """The plugin loaded as Uranium loads it processes a save while one stage of the real ``loadpath
    run`` child fails.  Before the write (splice, check, rename): Cura's chunks come back as they
    were, and the message says so; no report of an earlier run is left to be shown as the last one.
    The report (its metrics, its files): the G-code is processed, and the message says what the
    report lacks, in Cura's terms (never naming the runner's temporary files as the G-code)."""
    import hashlib

    require_tool("cura")
    chunks = cura_chunks(cura_file.read_text(encoding="utf-8"))
    sha = hashlib.sha256("".join(chunks).encode()).hexdigest()
    fault = faults / "fault"
    fault.write_text(stage, encoding="utf-8")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    prefs = {
        "loadcase": str(write_case(tmp_path)),
        "command": str(VENV_BIN / "loadpath"),
        "options": json.dumps({"engine": "streamlines"}),
        "on_save": True,
        "timeout": 300,
    }
    earlier_report = {"metrics.json": '{"source": "earlier.gcode", "changed": true}'}
    res = run_extension(
        tmp_path,
        {"chunks": chunks, "preferences": prefs, "earlier_report": earlier_report},
        LOADPATH_CACHE_DIR=str(faults / "cache"),
        PYTHONPATH=str(FAULTHOOK),
        LOADPATH_TEST_FAULT=str(fault),
        TMPDIR=str(tmp),
    )
    message, new = res["saved_message"], res["chunks"]
    assert hashlib.sha256("".join(chunks).encode()).hexdigest() == sha  # the test's own copy
    assert "/loadpath-cura-" not in message, message  # the runner's temporary files are no one's G-code
    assert "untouched" not in message and "was written" not in message
    assert list(tmp.iterdir()) == []  # the runner's temporary folder is gone, whatever failed
    earlier = Path(res["report_dir"])  # the last-report folder, which held an earlier run's report
    if stage in ("splice", "check", "rename"):
        reason = (  # a full disk is named by the folder to free (the temporary folder)
            f"cannot write loadpath's temporary file in {str(tmp)!r}: No space left on device"
            if stage == "rename"
            else "internal error (ValueError: forced failure); please report this"
        )
        assert message.startswith("Loadpath failed; the G-code is saved as Cura sliced it (its first line says why): ")
        assert reason in message, message
        first, rest = new[0].split("\n", 1)
        assert first == runner_error_comment(message.split("(its first line says why): ", 1)[1]).rstrip("\n")
        assert hashlib.sha256((rest + "".join(new[1:])).encode()).hexdigest() == sha  # as Cura sliced it
        assert not earlier.exists()  # no earlier report shown as this run's
        assert res["report_message"].startswith("No report of the last run"), res["report_message"]
    else:
        assert message.startswith("Stress-aligned infill written in "), message
        assert new != chunks and new[0].endswith(PROCESSED) and len(new) == len(chunks)
        verdict = message.splitlines()[1]
        assert verdict.startswith("loadpath ") and "replaced" in verdict
        # the G-code Cura saves is the processed one; its header was final before a report-files warning,
        # which the message's verdict counts
        written = verdict.replace("; 1 warning", "; 0 warnings") if stage == "report_files" else verdict
        assert stage != "report_files" or verdict.endswith("; 1 warning"), verdict
        assert new[0].splitlines()[1] == "; loadpath: " + written
        warnings = [ln for ln in message.splitlines() if ln.startswith("warning: ")]
        if stage == "metrics":  # the report is written, without its figures, and says so
            assert any("have no figures or metrics (ValueError: forced failure)" in w for w in warnings), message
            assert "No figures or metrics" in (earlier / "index.html").read_text("utf-8")
            assert "infill replaced" in res["report_message"] and "earlier" not in res["report_message"]
        else:  # the report's files could not be written: no part of it is kept as the last report
            assert warnings == ["warning: the report could not be written (No space left on device); "
                                "the stress-aligned G-code was made without it"], message
            assert not earlier.exists()
            assert res["report_message"].startswith("No report of the last run"), res["report_message"]


def runner_error_comment(message: str) -> str:
    """The runner's first line for a failure (loaded as the plugin loads it)."""
    return load_script(SCRIPTS.parent / "loadpath_runner.py", "runner_for_faults").error_comment(message)
