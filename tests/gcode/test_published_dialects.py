"""Published G-code from the slicers Debian cannot run (Bambu Studio, OrcaSlicer, SuperSlicer, Cura 5).

Provenance, licences and the search behind this list: ``tests/data/published/README.md``.

Two kinds of file are checked the same way (:data:`KNOWN`):

- committed files (``tests/data/published/``), whose licence allows redistribution;
- real files met in public repositories that carry no redistributable licence.  They are not
  committed; the tests read them from the folder named by ``LOADPATH_PUBLISHED_GCODE`` (file names
  as in :data:`KNOWN`, each checked by its SHA-256); without it they are not collected.  The
  README says where each one comes from.

What is checked, per file: the parse is lossless, the slicer and marker family are recognised,
layers and their Z are found, the infill the default replace set selects (internal solid) is found
on the expected layers with the pitch the slicer's configured line width gives, the embedded
configuration is read, and ``run_job`` either splices (every kept line untouched,
:func:`loadpath.splice.verify.check_splice`), passes the file through with the "nothing to replace"
warning, or fails with the one-line error expected for that file.

The tests at the end pin the parser fixes these files showed, on a few lines shaped like them.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from loadpath import gcode, geometry
from loadpath.errors import LoadpathError
from loadpath.gcode import Role, role_of
from loadpath.splice.verify import check_splice
from loadpath.plugin.job import JobRequest, run_job

COMMITTED = Path(__file__).resolve().parents[1] / "data" / "published"
EXTERNAL = os.environ.get("LOADPATH_PUBLISHED_GCODE", "")

CASE = """version = 1
[[supports]]
name = "clamp"
where = { side = "x_min", within = 3.0 }
fix = ["x", "y", "z"]

[[loads]]
name = "pull"
where = { side = "x_max", within = 3.0 }
force = [500.0, 0.0, 0.0]
"""


@dataclass(frozen=True)
class Published:
    """A real file and what a user must get from it."""

    name: str
    sha256: str
    committed: bool
    slicer: str
    version: str
    family: str
    n_layers: int
    z_first: float
    z_last: float
    height: float  #: mm, every layer
    replace_layers: tuple[int, ...] | None  #: 0-based layers where the default replace set finds
    #: blocks (None: long list, only checked against the slicer's own solid-infill layers)
    config: dict[str, str]
    objects: tuple[str, ...] = ()
    outcome: str = "spliced"  #: "spliced", "nothing" (passed through) or an error's text
    slow: bool = False
    config_pitch: bool = False  #: the replaced blocks' pitch is the configured solid line width's


KNOWN = (
    Published(
        name="bambustudio-02.04.00.70-a1mini-labels-arcs.gcode",
        sha256="",  # committed: no copy to check
        committed=True,
        slicer="BambuStudio",
        version="02.04.00.70",
        family="bambu",
        n_layers=1,
        z_first=0.2,
        z_last=0.2,
        height=0.2,
        replace_layers=(),
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.42",
            "sparse_infill_line_width": "0.45",
            "sparse_infill_density": "15%",
            "printer_model": "Bambu Lab A1 mini",
        },
        objects=("label id 215", "label id 171", "label id 193"),
        # the repository's own tool zeroed the E of the wall's G1 lines: no perimeter carries filament
        outcome="has infill but no perimeters",
    ),
    Published(  # OrcaSlicer on a Bambu printer: Bambu marker family, both object label styles
        name="orcaslicer-2.3.1-bambu-p1s-cube20.gcode",
        sha256="",
        committed=True,
        slicer="OrcaSlicer",
        version="2.3.1",
        family="bambu",
        n_layers=100,
        z_first=0.2,
        z_last=20.0,
        height=0.2,
        replace_layers=(1, 2, 94, 96, 97, 98),  # 95 (0-based 94): a one-bead ring of internal solid infill
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.42",
            "sparse_infill_density": "15%",
            "printer_model": "Bambu Lab P1S",
        },
        objects=("Object_1 id:0 copy 0",),
        config_pitch=True,
    ),
    Published(
        name="bambustudio-02.03.01.51-cube10.gcode",
        sha256="1e66ef2a944619ee7a6596e28668dd0d19ab61d8d60fce0f1a04de967e88633c",
        committed=False,
        slicer="BambuStudio",
        version="02.03.01.51",
        family="bambu",
        n_layers=50,
        z_first=0.2,
        z_last=10.0,
        height=0.2,
        replace_layers=(1, 2, 47, 48),
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.4",
            "sparse_infill_density": "20%",
            "layer_height": "0.2",
        },
        config_pitch=True,
    ),
    Published(
        name="bambustudio-01.09.07.52-square-ring.gcode",
        sha256="cfca3614e053d94f921e64a22a993b91bbe27b4fbb78623ad31d77acbc1cc349",
        committed=False,
        slicer="BambuStudio",
        version="01.09.07.52",
        family="bambu",
        n_layers=5,
        z_first=0.2,
        z_last=1.0,
        height=0.2,
        replace_layers=(),
        config={"nozzle_diameter": "0.4", "sparse_infill_density": "20%"},
        outcome="nothing",  # walls only
    ),
    Published(
        name="cura-5.4.0-basic-test.gcode",
        sha256="b2216d34f6b9cdcd5e242f78a390f58801b29e2b74ff5bc20b89a85c705ceff2",
        committed=False,
        slicer="Cura",
        version="5.4.0",
        family="cura",
        n_layers=6,
        z_first=0.2,
        z_last=1.2,
        height=0.2,
        replace_layers=(),  # SKIN only on exposed layers (bottom / top), FILL between
        config={},
        objects=("basic test.3mf", "basic test.3mf(1)"),
        outcome="nothing",
    ),
    Published(
        name="bambustudio-01.09.07.52-a1-hook.gcode",
        sha256="a44442ff31c3ab07b87318cb7c86341da0f5962bc3fd04c3f2b12223dedc3483",
        committed=False,
        slicer="BambuStudio",
        version="01.09.07.52",
        family="bambu",
        n_layers=45,
        z_first=0.2,
        z_last=9.0,
        height=0.2,
        replace_layers=(1, 2, 33, 34, 35, 36, 37, 38, 39, 41, 42, 43),
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.42",
            "sparse_infill_density": "15%",
            "printer_model": "Bambu Lab A1",
        },
        slow=True,  # the run takes about 30 s
    ),
    Published(
        name="orca-flashforge-1.3.0-ad5m.gcode",
        sha256="3f43b5f36e0035a10948159936597596b0866a134e0d59f9a9ab4ec69a168015",
        committed=False,
        slicer="OrcaSlicer",
        version="1.3.0 (Orca-Flashforge)",
        family="prusa",
        n_layers=10,
        z_first=0.2,
        z_last=2.0,
        height=0.2,
        replace_layers=(1, 2, 3, 5, 6, 7, 8),
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.42",
            "sparse_infill_density": "15%",
            "printer_model": "Flashforge Adventurer 5M Pro",
        },
        # two separate pieces; the small one (x -33..-32) is not held by the x_min clamp
        outcome="free to translate",
        slow=True,
        config_pitch=True,
    ),
    Published(
        name="orcaslicer-2.4.0-alpha-ad5m.gcode",
        sha256="35e54cfc7d7f6b4f35c9d3d09ed94234c9be50b666b5fb12443c4202928d41f2",
        committed=False,
        slicer="OrcaSlicer",
        version="2.4.0-alpha",
        family="prusa",
        n_layers=240,
        z_first=0.2,
        z_last=48.0,
        height=0.2,
        replace_layers=None,
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.42",
            "sparse_infill_density": "15%",
            "printer_model": "Flashforge Adventurer 5M Pro",
            "gcode_flavor": "klipper",
        },
        slow=True,  # 2.9 MB, 240 layers: the run takes about 150 s
    ),
    Published(  # OrcaSlicer on a Bambu printer: the Bambu marker family, both object label styles
        name="orcaslicer-2.3.1-bambu-p1s-cube.gcode",
        sha256="e4f33a8d399628c889bac770c9eeb5a105140e50052f3a15f9a297032ff886ee",
        committed=False,
        slicer="OrcaSlicer",
        version="2.3.1",
        family="bambu",
        n_layers=50,
        z_first=0.2,
        z_last=10.0,
        height=0.2,
        replace_layers=(1, 2, 44, 46, 47, 48),
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.42",
            "sparse_infill_density": "25%",
            "printer_model": "Bambu Lab P1S",
        },
        objects=("input id:0 copy 0",),
        config_pitch=True,
    ),
    Published(  # two objects, two filaments, a prime tower
        name="bambustudio-02.05.00.66-two-filaments.gcode",
        sha256="e91b79cca7e3e78fc79d3badc0bfa349e46806df7228c61bd3485b5d646cbf17",
        committed=False,
        slicer="BambuStudio",
        version="02.05.00.66",
        family="bambu",
        n_layers=100,
        z_first=0.2,
        z_last=20.0,
        height=0.2,
        replace_layers=(1, 2, 46, 47, 48, 96, 97, 98),
        config={
            "nozzle_diameter": "0.4",
            "internal_solid_infill_line_width": "0.42",
            "sparse_infill_density": "15%",
            "printer_model": "Bambu Lab P1S",
        },
        objects=("label id 89", "label id 111"),
        config_pitch=True,
    ),
)

REFUSED = (
    # (name, sha256, the one-line error): real files the reader must refuse
    (
        "orcaslicer-2.3.0-ad5m.gcode",
        "45edbca2928d5ea632c1aa46b84326be92708e5fa2e908a4df0690b6dfd6d279",
        # stops after 'M73 P100 R0' without a line ending, its '; EXECUTABLE_BLOCK_START' never closed
        "ends without the closing '; EXECUTABLE_BLOCK_END' line: it looks truncated",
    ),
)


def _path(pf: Published) -> Path:
    if pf.committed:
        return COMMITTED / pf.name
    return _external(pf.name, pf.sha256)


def _external(name: str, sha256: str) -> Path:
    if not EXTERNAL:
        pytest.skip(f"{name} is not redistributable; set LOADPATH_PUBLISHED_GCODE to a folder holding it")
    path = Path(EXTERNAL) / name
    if not path.is_file():
        pytest.skip(f"{path} absent (see tests/data/published/README.md for its source)")
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    assert digest == sha256, f"{path} is not the published file (sha256 {digest})"
    return path


def _available(name: str) -> bool:
    """An external file is tested only where it was provided: a run without it lists no skipped
    test for it (CI runs every collected test; only the committed files are there)."""
    return bool(EXTERNAL) and (Path(EXTERNAL) / name).is_file()


PARAMS = [
    pytest.param(pf, id=pf.name.rsplit(".", 1)[0], marks=[pytest.mark.slow] if pf.slow else [])
    for pf in KNOWN
    if pf.committed or _available(pf.name)
]


def _solid_layers(program) -> set[int]:
    """Layers where the slicer itself wrote internal solid infill (Cura: SKIN)."""
    m = program.moves
    solid_role = Role.SKIN if program.dialect.family == "cura" else Role.SOLID_INFILL
    return set(np.unique(m["layer"][m["extrude"] & (m["role"] == solid_role)]).tolist())


@pytest.mark.parametrize("pf", PARAMS)
def test_parse_is_lossless_and_the_dialect_recognised(pf):
    path = _path(pf)
    raw = path.read_bytes()
    program = gcode.read(path)
    assert program.to_bytes() == raw
    d = program.dialect
    assert (d.slicer, d.version, d.family) == (pf.slicer, pf.version, pf.family)
    assert program.objects == pf.objects
    # every extrusion's feature name is one the role table knows
    m = program.moves
    body = m["extrude"] & (m["layer"] >= 0)
    unknown = {program.features[f] for f in np.unique(m["feature"][body & (m["role"] == Role.OTHER)])}
    assert not unknown, f"feature names without a role: {unknown}"


@pytest.mark.parametrize("pf", PARAMS)
def test_layers_and_their_z(pf):
    program = gcode.read(_path(pf))
    layers = program.layers
    assert len(layers) == pf.n_layers
    z = np.array([layer.z for layer in layers])
    assert z[0] == pytest.approx(pf.z_first) and z[-1] == pytest.approx(pf.z_last)
    assert (np.diff(z) > 0).all()
    # OrcaSlicer writes some heights with float noise (';HEIGHT:0.199997' in 2.4.0-alpha)
    np.testing.assert_allclose([layer.height for layer in layers], pf.height, atol=1e-5)
    # the extrusions of each layer sit at its Z
    m = program.moves
    ext = m[m["extrude"] & (m["layer"] >= 0) & ~m["lift"]]
    np.testing.assert_allclose(ext["z1"], z[ext["layer"]], atol=1e-6)


@pytest.mark.parametrize("pf", PARAMS)
def test_embedded_config_is_read(pf):
    program = gcode.read(_path(pf))
    for key, value in pf.config.items():
        assert program.config.get(key) == value, key


@pytest.mark.parametrize("pf", [p for p in PARAMS if p.values[0].outcome != "has infill but no perimeters"])
def test_default_replace_kinds_per_layer(pf):
    """Internal solid infill (the default replace set) is found on the expected layers, only where the
    slicer wrote internal solid infill, and (``config_pitch``) at the pitch of the slicer's configured
    line width (rounded-rectangle bead spacing ``w - h (1 - pi/4)``).  The geometry is derived the way
    the pipeline derives it (``check=False``: blocks that leave their region are kept as sliced)."""
    program = gcode.read(_path(pf))
    geo = geometry.layer_geometry(program, check=False)
    found: dict[int, list] = {}
    for obj in geo.objects:
        for layer in obj.layers:
            for island in layer.islands:
                blocks = island.replaced(list(geometry.DEFAULT_REPLACE))
                if blocks:
                    found.setdefault(layer.layer_index, []).extend(blocks)
    solid_layers = _solid_layers(program)
    assert set(found) <= solid_layers
    if pf.replace_layers is None:
        assert len(found) > len(solid_layers) / 2
    else:
        assert tuple(sorted(found)) == pf.replace_layers
    if pf.config_pitch:
        spacing = float(program.config["internal_solid_infill_line_width"]) - pf.height * (1 - math.pi / 4)
        pitches = [b.pitch for blocks in found.values() for b in blocks]
        assert abs(np.median(pitches) - spacing) < 0.02, (np.median(pitches), spacing)


@pytest.mark.parametrize("pf", PARAMS)
def test_loadpath_run(pf, tmp_path):
    """``run_job`` on the file, through the real pipeline (streamlines engine, one worker)."""
    path = _path(pf)
    raw = path.read_bytes()
    src = tmp_path / pf.name
    src.write_bytes(raw)
    case = tmp_path / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    out = tmp_path / "out.gcode"
    request = JobRequest(src, case, output=out, cli={"engine": "streamlines", "jobs": 1})
    if pf.outcome not in ("spliced", "nothing"):
        with pytest.raises(LoadpathError) as info:
            run_job(request)
        message = str(info.value)
        assert pf.outcome in message and "\n" not in message
        assert src.read_bytes() == raw and not out.exists()
        return
    result = run_job(request)
    assert result.error is None
    assert src.read_bytes() == raw
    if pf.outcome == "nothing":
        assert not result.changed
        assert any("nothing to replace" in w for w in result.warnings), result.warnings
        return
    assert result.changed and out.exists()
    program = gcode.read(src)
    output = gcode.read(out)
    check = check_splice(program, output, result.pipeline.splice, volume_tol=0.03)
    assert check.problems == [], check.problems[:3]
    replaced_layers = {report.layer for report in result.pipeline.splice.blocks}
    assert replaced_layers <= set(
        pf.replace_layers if pf.replace_layers is not None else _solid_layers(program)
    )
    assert output.dialect == program.dialect and len(output.layers) == len(program.layers)


# --------------------------------------------------------------------- fixes the real files showed

_BAMBU_HEAD = """; HEADER_BLOCK_START
; BambuStudio 02.03.01.51
; total layer number: 1
; HEADER_BLOCK_END

; CONFIG_BLOCK_START
; layer_height = 0.2
{config_line}
; wall_loops = 2
; CONFIG_BLOCK_END

; THUMBNAIL_BLOCK_START
; thumbnail begin 50x50 8
; iVBORw0K
; thumbnail end
; THUMBNAIL_BLOCK_END

; EXECUTABLE_BLOCK_START
M83
; CHANGE_LAYER
; Z_HEIGHT: 0.2
; LAYER_HEIGHT: 0.2
; FEATURE: Outer wall
; LINE_WIDTH: 0.42
G1 X10 Y10 F9000
G1 X20 Y10 E1.0 F1800
; EXECUTABLE_BLOCK_END

"""


@pytest.mark.parametrize(
    "config_line",
    ["; thumbnail_size = 50x50", "; thumbnails = 140x110/PNG"],
    ids=["bambu-thumbnail_size", "orca-thumbnails"],
)
def test_a_config_key_named_like_a_thumbnail_does_not_hide_the_config_end(config_line):
    """Bambu Studio writes ``; thumbnail_size = 50x50`` inside its config block, which comes before its
    thumbnail block (every real Bambu Studio file with a thumbnail, 01.09 and 02.03).  Counting that
    line as a thumbnail marker shifted the begin/end pairing, the skipped rows swallowed
    ``; CONFIG_BLOCK_END`` and every such file was refused as truncated."""
    text = _BAMBU_HEAD.format(config_line=config_line)
    program = gcode.parse(text)  # strict: the structural checks run
    assert program.to_bytes() == text.encode()
    key, value = config_line[2:].split(" = ")
    assert program.config == {"layer_height": "0.2", key: value, "wall_loops": "2"}
    assert len(program.layers) == 1


def test_a_truncated_bambu_file_is_still_refused():
    """The fix must not hide a real truncation: the same file cut before its last line."""
    text = _BAMBU_HEAD.format(config_line="; thumbnail_size = 50x50")
    cut = text[: text.index("; EXECUTABLE_BLOCK_END")]
    with pytest.raises(LoadpathError, match="EXECUTABLE_BLOCK_END.*truncated"):
        gcode.parse(cut)


def test_floating_vertical_shell_is_a_wall():
    """Bambu Studio 2.x ``Floating vertical shell``: a closed loop just inside the inner wall over sparse
    infill below the top shells (layer 46 of the 10 mm cube above).  As a wall it bounds the infill
    domain; unknown (``Role.OTHER``) it was ignored, and replaced sparse infill would cross it."""
    assert role_of("Floating vertical shell") == Role.PERIMETER


_ORCA_FORK = """; HEADER_BLOCK_START
; generated by {header} on 2025-05-04 at 17:53:29
; total layer number: 1
; HEADER_BLOCK_END

; EXECUTABLE_BLOCK_START
M83
;LAYER_CHANGE
;Z:0.2
;HEIGHT:0.2
;TYPE:Outer wall
;WIDTH:0.42
G1 X10 Y10 F9000
G1 X20 Y10 E1.0 F1800
; EXECUTABLE_BLOCK_END

; CONFIG_BLOCK_START
; layer_height = 0.2
; CONFIG_BLOCK_END
"""


@pytest.mark.parametrize(
    ("header", "version"),
    [
        ("Orca-Flashforge 1.3.0", "1.3.0 (Orca-Flashforge)"),
        ("Snapmaker Orca 2.3.4", "2.3.4 (Snapmaker Orca)"),
        ("Flash Studio 1.7.6", "1.7.6 (Flash Studio)"),
    ],
)
def test_orca_forks_are_recognised(header, version):
    """Real files of OrcaSlicer forks name the fork in the header (``; generated by Orca-Flashforge
    1.3.0 on ...``); they were 'unknown' slicers, so Orca's truncation rule did not apply to them."""
    text = _ORCA_FORK.format(header=header)
    program = gcode.parse(text)
    assert (program.dialect.slicer, program.dialect.version, program.dialect.family) == (
        "OrcaSlicer",
        version,
        "prusa",
    )
    with pytest.raises(LoadpathError, match="CONFIG_BLOCK_END"):
        gcode.parse(text[: text.index("; CONFIG_BLOCK_START")])  # only Orca's own rule sees this


_TRUNCATED = "orcaslicer-2.3.1-bambu-p1s-cube20.gcode"  # committed; cut at 90 % of its bytes below
_REFUSED_HERE = [r for r in REFUSED if _available(r[0])] + [
    (_TRUNCATED, "", "ends without the closing '; EXECUTABLE_BLOCK_END' line: it looks truncated")
]


@pytest.mark.parametrize(
    ("name", "sha256", "error"),
    _REFUSED_HERE,
    ids=[r[0].rsplit(".", 1)[0] + ("-cut" if not r[1] else "") for r in _REFUSED_HERE],
)
def test_refused_files_get_the_one_line_error(name, sha256, error, tmp_path):
    if sha256:
        path = _external(name, sha256)
    else:  # an interrupted copy of a committed real file: cut mid-line, as the real 2.3.0 one is
        data = (COMMITTED / name).read_bytes()
        path = tmp_path / name
        path.write_bytes(data[: int(len(data) * 0.9)])
    with pytest.raises(LoadpathError) as info:
        gcode.read(path)
    assert error in str(info.value) and "\n" not in str(info.value)
    case = tmp_path / "case.toml"
    case.write_text(CASE, encoding="utf-8")
    out = tmp_path / "out.gcode"
    with pytest.raises(LoadpathError, match="truncated"):
        run_job(JobRequest(path, case, output=out, cli={"engine": "streamlines", "jobs": 1}))
    assert not out.exists()


_ORCA_ON_BAMBU = """; HEADER_BLOCK_START
; generated by OrcaSlicer 2.3.1 on 2026-04-03 at 14:28:37
; HEADER_BLOCK_END
; EXECUTABLE_BLOCK_START
M83
; CHANGE_LAYER
; Z_HEIGHT: 0.2
; LAYER_HEIGHT: 0.2
; printing object {first} id:0 copy 0
; start printing object, unique label id: 8
M624 AQAAAAAAAAA=
; FEATURE: Outer wall
; LINE_WIDTH: 0.42
G1 X10 Y10 F9000
G1 X20 Y10 E1.0 F1800
; stop printing object {first} id:0 copy 0
; CHANGE_LAYER
; Z_HEIGHT: 0.4
; LAYER_HEIGHT: 0.2
; stop printing object, unique label id: 8
M625
; printing object {second} id:0 copy 0
M204 S10000
; start printing object, unique label id: 8
M624 AQAAAAAAAAA=
; FEATURE: Outer wall
G1 X10 Y20 E1.0
; stop printing object {second} id:0 copy 0
; stop printing object, unique label id: 8
M625
; EXECUTABLE_BLOCK_END
; CONFIG_BLOCK_START
; layer_height = 0.2
; CONFIG_BLOCK_END
"""


def test_orca_on_a_bambu_printer_labels_each_object_once():
    """OrcaSlicer 2.3.1 on a Bambu Lab P1S (real file, bambox) opens every object with both label styles,
    the Prusa one first (an ``M204`` may sit between).  It was two objects, the extrusions under the
    opaque ``label id 8`` and the readable name owning none; now one object under the readable name."""
    program = gcode.parse(_ORCA_ON_BAMBU.format(first="input", second="input"))
    assert program.objects == ("input id:0 copy 0",)
    m = program.moves
    assert (m["object"][m["extrude"]] == 0).all()
    # different partners for the same Bambu id: not one object, nothing merged
    program = gcode.parse(_ORCA_ON_BAMBU.format(first="input", second="other"))
    assert program.objects == ("label id 8", "input id:0 copy 0", "other id:0 copy 0")
