"""Real slicer output for the tests: test parts as STL, sliced by PrusaSlicer 2.5 and CuraEngine 4.13.

Shared by every test folder (the session fixtures live in ``tests/fixtures.py``) and by
``scripts/make_fixtures.py``, which regenerates the shipped example.  Nothing here is mocked: the
functions run the real ``prusa-slicer`` and ``CuraEngine`` and raise :class:`SlicerError` on anything
the slicer reports as an error (CuraEngine exits 0 on a missing definition and only prints
``[ERROR]`` on stderr, so stderr is checked, not just the exit status).

Parts (millimetres, bounding box starting at the origin unless said otherwise):

- :func:`ohs_mesh` — open-hole tensile specimen of ASTM D5766: 150 x 36 x 2 with a 6 mm hole in the centre.
- :func:`two_islands_mesh` — two 40 x 20 x 2 plates 10 mm apart: one object, two islands per layer.
- :func:`bracket_mesh` — an L-bracket (concave outline) 60 x 40 x 3, legs 15 wide, 5 mm bolt hole.
- :func:`tower_mesh` — a 30 x 20 plate with an 8 mm hole extruded 24 mm high with a twist and a taper,
  so the outline changes with height (120 layers at 0.2 mm); :func:`tower_layers` gives the same part
  as layer outlines without slicing.

Settings (keyword dictionaries for :func:`slice_prusa` / :func:`slice_cura`):

- ``PRUSA_MIXED`` / ``CURA_MIXED`` — 20 % sparse infill and 2 top / 2 bottom solid layers: a 10-layer
  part gets solid bottoms, sparse ``Internal infill`` / ``FILL`` layers and solid tops.
- ``PRUSA_SOLID`` / ``CURA_SOLID`` — the same at 100 % density (rectilinear / lines).
- ``PRUSA_EXAMPLE`` — the shipped example: 100 % infill, 3 top / 3 bottom solid layers.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import trimesh
from shapely import affinity
from shapely.geometry import Point, Polygon, box

__all__ = [
    "SlicerError",
    "PRUSA_PROFILES",
    "PRUSA_PRESETS",
    "CURA_RESOURCES",
    "PRUSA_MIXED",
    "PRUSA_SOLID",
    "PRUSA_EXAMPLE",
    "CURA_MIXED",
    "CURA_SOLID",
    "ohs_mesh",
    "two_islands_mesh",
    "bracket_mesh",
    "tower_mesh",
    "taper_mesh",
    "shelf_bracket_mesh",
    "tower_layers",
    "PARTS",
    "write_stl",
    "flatten_prusa_presets",
    "write_prusa_profile",
    "slice_prusa",
    "slice_cura",
    "prusa_version",
    "cura_version",
]

PRUSA_PROFILES = Path("/usr/share/PrusaSlicer/profiles/PrusaResearch.ini")
PRUSA_PRESETS = {
    "printer": "Original Prusa i3 MK3S & MK3S+",
    "print": "0.20mm QUALITY @MK3",
    "filament": "Prusament PLA",
}
CURA_RESOURCES = Path(os.environ.get("CURA_RESOURCES", "/usr/share/cura/resources"))

# real-tools.md §3.4: the MK3S print preset has 6 top / 4 bottom solid layers and minimum shell
# thicknesses, which make a 2 mm part all solid; these settings give both kinds of infill layer.
PRUSA_MIXED: dict[str, str] = {
    "fill_density": "20%",
    "fill_pattern": "rectilinear",
    "top_solid_layers": "2",
    "bottom_solid_layers": "2",
    "top_solid_min_thickness": "0",
    "bottom_solid_min_thickness": "0",
}
PRUSA_SOLID: dict[str, str] = {**PRUSA_MIXED, "fill_density": "100%"}
PRUSA_EXAMPLE: dict[str, str] = {
    **PRUSA_SOLID,
    "top_solid_layers": "3",
    "bottom_solid_layers": "3",
}
# real-tools.md §4.2: CuraEngine ignores the frontend's formulas, so derived keys are set explicitly.
CURA_MIXED: dict[str, str] = {
    "layer_height": "0.2",
    "layer_height_0": "0.2",
    "infill_sparse_density": "20",
    "infill_line_distance": "4.0",  # = line width 0.4 * 100 / 20 * 2 / 2 (lines pattern)
    "infill_pattern": "lines",
    "top_layers": "2",
    "bottom_layers": "2",
    "initial_bottom_layers": "2",
}
CURA_SOLID: dict[str, str] = {**CURA_MIXED, "infill_sparse_density": "100", "infill_line_distance": "0.4"}


class SlicerError(RuntimeError):
    """A real slicer failed or reported an error; the message carries its command and stderr."""


# --------------------------------------------------------------------------------------------------
# Parts


def _to_trimesh(m) -> trimesh.Trimesh:
    mesh = m.to_mesh()
    return trimesh.Trimesh(vertices=np.asarray(mesh.vert_properties)[:, :3], faces=np.asarray(mesh.tri_verts))


def _at_origin(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    mesh = mesh.copy()
    mesh.apply_translation(-mesh.bounds[0])
    if not mesh.is_watertight:
        raise SlicerError("test part is not watertight")
    return mesh


def ohs_mesh(
    length: float = 150.0, width: float = 36.0, thickness: float = 2.0, hole: float = 6.0
) -> trimesh.Trimesh:
    """Open-hole tensile specimen (ASTM D5766), bounding box from the origin, mm."""
    box = trimesh.creation.box(extents=(length, width, thickness))
    cyl = trimesh.creation.cylinder(radius=hole / 2, height=thickness * 3, sections=64)
    return _at_origin(box.difference(cyl))


def two_islands_mesh(
    size: tuple[float, float] = (40.0, 20.0), gap: float = 10.0, thickness: float = 2.0
) -> trimesh.Trimesh:
    """Two plates side by side in one mesh: one object with two islands per layer."""
    a = trimesh.creation.box(extents=(*size, thickness))
    b = a.copy()
    b.apply_translation((size[0] + gap, 0.0, 0.0))
    return _at_origin(trimesh.util.concatenate([a, b]))


def bracket_mesh(
    legs: tuple[float, float] = (60.0, 40.0),
    leg_width: float = 15.0,
    thickness: float = 3.0,
    hole: float = 5.0,
) -> trimesh.Trimesh:
    """L-bracket (concave outline) with a bolt hole in the long leg."""
    import manifold3d as mf

    lx, ly = legs
    outline = [(0, 0), (lx, 0), (lx, leg_width), (leg_width, leg_width), (leg_width, ly), (0, ly)]
    cs = mf.CrossSection([outline])
    hole_cs = mf.CrossSection.circle(hole / 2, 48).translate((lx - leg_width / 2, leg_width / 2))
    solid = mf.Manifold.extrude(cs - hole_cs, thickness)
    return _at_origin(_to_trimesh(solid))


def shelf_bracket_mesh(
    legs: tuple[float, float] = (120.0, 100.0), cut_out: float = 50.0, thickness: float = 3.0
) -> trimesh.Trimesh:
    """A triangular shelf bracket (right angle at the origin) with a round lightening cut-out.

    The cut-out (``cut_out`` mm across) is larger than the report's close-up window (about 30 mm),
    which once put the whole window inside the hole.
    """
    import manifold3d as mf

    lx, ly = legs
    cs = mf.CrossSection([[(0, 0), (lx, 0), (0, ly)]])
    hole = mf.CrossSection.circle(cut_out / 2, 96).translate((0.29 * lx, 0.3 * ly))
    return _at_origin(_to_trimesh(mf.Manifold.extrude(cs - hole, thickness)))


def taper_mesh(
    length: float = 80.0, width: float = 12.0, root: float = 3.6, tip: float = 1.2
) -> trimesh.Trimesh:
    """A cantilever tapering in height from ``root`` mm at x = 0 to ``tip`` mm at ``x = length``: its
    top is a slope, so every layer has a solid strip under that layer's top skin beside the
    layer's internal infill (at 100 % both solid: one island, two blocks of one kind)."""
    import manifold3d as mf

    profile = mf.CrossSection([[(0.0, 0.0), (length, 0.0), (length, tip), (0.0, root)]])
    return _at_origin(_to_trimesh(mf.Manifold.extrude(profile, width).rotate((90, 0, 0))))


def tower_mesh(
    size: tuple[float, float] = (30.0, 20.0),
    height: float = 24.0,
    hole: float = 8.0,
    twist_deg: float = 30.0,
    scale_top: float = 0.6,
) -> trimesh.Trimesh:
    """A twisted, tapered plate with a hole: >= 100 layers whose outline changes with height."""
    import manifold3d as mf

    sx, sy = size
    cs = mf.CrossSection.square((sx, sy), center=True) - mf.CrossSection.circle(hole / 2, 48)
    solid = mf.Manifold.extrude(
        cs, height, n_divisions=48, twist_degrees=twist_deg, scale_top=(scale_top, scale_top)
    )
    return _at_origin(_to_trimesh(solid))


def tower_layers(
    n: int = 120,
    dz: float = 0.2,
    twist_deg: float = 30.0,
    scale_top: float = 0.6,
    at: tuple[float, float] = (100.0, 80.0),
) -> list[tuple[float, float, Polygon]]:
    """The :func:`tower_mesh` part as layer outlines, without slicing: ``(z0, z1, outline)`` per layer.

    Each layer's outline is the plate scaled and twisted as at its mid-height, centred at ``at``
    (mm, where the slicer puts the part on the bed); for :meth:`loadpath.loadcase.Body.from_layers`.
    """
    plate = box(-15, -10, 15, 10).difference(Point(0, 0).buffer(4, quad_segs=12))
    layers = []
    for i in range(n):
        t = (i + 0.5) / n
        s = 1.0 + (scale_top - 1.0) * t
        g = affinity.rotate(affinity.scale(plate, s, s, origin=(0, 0)), twist_deg * t, origin=(0, 0))
        layers.append((i * dz, (i + 1) * dz, affinity.translate(g, *at)))
    return layers


PARTS = {
    "ohs": ohs_mesh,
    "two_islands": two_islands_mesh,
    "bracket": bracket_mesh,
    "tower": tower_mesh,
    "shelf": shelf_bracket_mesh,
}


def write_stl(mesh: trimesh.Trimesh, path: str | os.PathLike) -> Path:
    """Write a binary STL; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)
    return path


# --------------------------------------------------------------------------------------------------
# PrusaSlicer profiles (real-tools.md §3.2)

_META_KEYS = {
    "inherits",
    "renamed_from",
    "alias",
    "compatible_printers",
    "compatible_printers_condition",
    "compatible_prints",
    "compatible_prints_condition",
}


def _read_bundle(path: Path) -> dict[tuple[str, str], dict[str, str]]:
    sections: dict[tuple[str, str], dict[str, str]] = {}
    current: dict[str, str] | None = None
    for raw in path.read_text(encoding="utf-8").splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        m = re.fullmatch(r"\[(\w+):(.+)\]", line)
        if m:
            current = sections.setdefault((m.group(1), m.group(2).strip()), {})
            continue
        if line.startswith("["):
            current = None  # [vendor], [obsolete_presets], ...
            continue
        if current is not None and "=" in line:
            key, value = line.split("=", 1)
            current[key.strip()] = value.strip()
    return sections


def _resolve(sections: dict, kind: str, name: str, seen: tuple[str, ...] = ()) -> dict[str, str]:
    if name in seen:
        raise SlicerError(f"cyclic 'inherits' in {kind}:{name}")
    try:
        own = sections[(kind, name)]
    except KeyError:
        raise SlicerError(f"preset [{kind}:{name}] not found in {PRUSA_PROFILES}") from None
    merged: dict[str, str] = {}
    for parent in own.get("inherits", "").split(";"):
        parent = parent.strip().strip('"')
        if parent:
            merged.update(_resolve(sections, kind, parent, (*seen, name)))
    merged.update(own)
    return merged


def flatten_prusa_presets(
    bundle: Path = PRUSA_PROFILES, presets: Mapping[str, str] = PRUSA_PRESETS
) -> dict[str, dict[str, str]]:
    """Resolve the ``inherits`` chains of the bundled MK3S presets into flat key/value dicts.

    Returns ``{"printer": {...}, "print": {...}, "filament": {...}}`` without the meta keys.
    """
    sections = _read_bundle(Path(bundle))
    out = {}
    for kind, name in presets.items():
        flat = _resolve(sections, kind, name)
        out[kind] = {k: v for k, v in flat.items() if k not in _META_KEYS}
    return out


def write_prusa_profile(folder: str | os.PathLike) -> list[Path]:
    """Write ``mk3s_printer.ini``, ``mk3s_print.ini``, ``mk3s_filament.ini`` into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for kind, flat in flatten_prusa_presets().items():
        p = folder / f"mk3s_{kind}.ini"
        if not p.exists():
            tmp = p.with_suffix(f".{os.getpid()}.tmp")  # test processes may write the same folder at once
            tmp.write_text("".join(f"{k} = {v}\n" for k, v in sorted(flat.items())), encoding="utf-8")
            tmp.replace(p)
        paths.append(p)
    return paths


# --------------------------------------------------------------------------------------------------
# Running the slicers


def _one_cpu() -> None:
    """Pin this (child) process to one of the CPUs it may use (``preexec_fn`` of :func:`_run`)."""
    cpus = sorted(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpus[os.getpid() % len(cpus)]})


def _run(
    cmd: list[str], env: dict[str, str] | None = None, cwd: Path | None = None, one_cpu: bool = False
) -> subprocess.CompletedProcess:
    exe = shutil.which(cmd[0])
    if exe is None:
        raise SlicerError(f"{cmd[0]} is not installed")
    pin = _one_cpu if one_cpu and hasattr(os, "sched_setaffinity") else None
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd, timeout=600, preexec_fn=pin)
    errors = [ln for ln in proc.stderr.splitlines() if re.search(r"\[(error|ERROR|fatal)\]|^error:", ln)]
    if proc.returncode != 0 or errors:
        tail = "\n".join(errors or proc.stderr.splitlines()[-15:])
        raise SlicerError(f"{' '.join(cmd)} failed (exit {proc.returncode}):\n{tail}")
    return proc


PRUSA_ENV = {
    "PATH": "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin",
    "HOME": "/tmp",
    "LANG": "C.UTF-8",
    "LC_ALL": "C.UTF-8",
}
"""The whole environment PrusaSlicer runs in (:func:`slice_prusa`).

PrusaSlicer 2.5 on one CPU writes the same file every time from the same process image, but not
from another: the bench's L-bracket sliced into folders whose names differ in length came out
with 12 coordinates round its bolt hole moved by up to 0.08 mm (2026-12-06), and so did the same
call with one more environment variable.  What its memory holds at start (the arguments and the
environment) decides them, so it is given the same of both wherever it runs: this environment,
and its files under fixed names in a folder of its own (the STLs keep their names, which the
G-code prints as the objects' names).  Tests on a slice then see the file CI sees."""


def slice_prusa(
    stl: str | os.PathLike | Sequence[str | os.PathLike],
    out: str | os.PathLike,
    *,
    one_cpu: bool = True,
    **overrides: str | float | int,
) -> Path:
    """Slice with PrusaSlicer 2.5 and the flattened MK3S presets (relative E).

    PrusaSlicer 2.5 on several threads does not slice an STL to the same bytes twice (its gyroid
    coordinates differ in the third decimal, 2026-12-05), and the model's first-ply failure load
    follows such differences by up to 17 %; on one CPU (``one_cpu``, the default) its slices are
    the same every time, so tests and benchmarks that compare files see the same input.  A benchmark
    that times the slicer as the user runs it passes ``one_cpu=False``.

    Parameters
    ----------
    stl : path or sequence of paths
        One STL per object (PrusaSlicer arranges several objects on the bed).
    out : path
        The G-code to write (its folder also receives the flattened profile and an overrides file).
    **overrides
        PrusaSlicer config keys (``fill_density="100%"``); they are loaded after the presets.

    Returns
    -------
    Path of the written G-code.  Raises :class:`SlicerError` when PrusaSlicer fails.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    profile = write_prusa_profile(out.parent / "mk3s_profile")
    stls = [Path(stl)] if isinstance(stl, (str, os.PathLike)) else [Path(s) for s in stl]
    if overrides:  # kept beside the output for the record
        ov = out.with_suffix(".overrides.ini")
        ov.write_text("".join(f"{k} = {v}\n" for k, v in sorted(overrides.items())), encoding="utf-8")
    # PrusaSlicer sees only fixed names in a folder of its own, and PRUSA_ENV (see there)
    with tempfile.TemporaryDirectory(prefix="prusa-") as tmp:
        work = Path(tmp)
        cmd = ["prusa-slicer", "--export-gcode"]
        if len(stls) > 1:
            cmd.append("--merge")  # one plate with one object per STL (else each STL is exported alone)
        for p in profile:
            (work / p.name).symlink_to(p.resolve())
            cmd += ["--load", p.name]
        if overrides:
            (work / "overrides.ini").symlink_to(ov.resolve())
            cmd += ["--load", "overrides.ini"]
        names = []
        for k, s in enumerate(stls):
            name = s.name if s.name not in names else f"{k}/{s.name}"  # the same name twice: a subfolder
            (work / name).parent.mkdir(exist_ok=True)
            (work / name).symlink_to(s.resolve())
            names.append(name)
        cmd += ["--output", "out.gcode", *names]
        _run(cmd, env=PRUSA_ENV, cwd=work, one_cpu=one_cpu)
        made = work / "out.gcode"
        if not made.is_file() or made.stat().st_size == 0:
            raise SlicerError(f"prusa-slicer wrote no G-code for {out}")
        shutil.move(made, out)
    return out


def slice_cura(
    stl: str | os.PathLike | Sequence[str | os.PathLike],
    out: str | os.PathLike,
    definition: str = "prusa_i3_mk3",
    **settings: str | float | int,
) -> Path:
    """Slice with CuraEngine 4.13 and the ``prusa_i3_mk3`` machine definition (absolute E).

    Each part is centred on the bed with ``mesh_position_x/y`` (CuraEngine puts the STL origin at the
    bed centre); several STLs are placed side by side along x, 10 mm apart.

    Parameters
    ----------
    stl : path or sequence of paths
    out : path
    definition : str
        Machine definition id in ``CURA_RESOURCES/definitions``.
    **settings
        Global settings (``-s key=value``), e.g. ``top_layers=2``.

    Returns
    -------
    Path of the written G-code (its stderr, with every resolved setting, is kept next to it as
    ``<name>.stderr.txt``).  Raises :class:`SlicerError` on a non-zero exit or any ``[ERROR]``.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    stls = [Path(stl)] if isinstance(stl, (str, os.PathLike)) else [Path(s) for s in stl]
    defs = CURA_RESOURCES / "definitions"
    extr = CURA_RESOURCES / "extruders"
    machine = defs / f"{definition}.def.json"
    extruder = extr / f"{definition}_extruder_0.def.json"
    for f in (machine, extruder):
        if not f.is_file():
            raise SlicerError(f"Cura definition {f} is missing: apt-get install cura")
    env = {**os.environ, "CURA_ENGINE_SEARCH_PATH": f"{defs}:{extr}"}
    cmd = ["CuraEngine", "slice", "-v", "-j", str(machine)]
    for k, v in settings.items():
        cmd += ["-s", f"{k}={v}"]
    cmd += ["-e0", "-j", str(extruder)]
    bounds = [trimesh.load_mesh(s).bounds for s in stls]
    total = sum(b[1][0] - b[0][0] for b in bounds) + 10.0 * (len(stls) - 1)
    x = -total / 2
    for s, b in zip(stls, bounds, strict=True):
        size = b[1] - b[0]
        cmd += [
            "-l",
            str(s),
            "-s",
            f"mesh_position_x={x - b[0][0]:.4f}",
            "-s",
            f"mesh_position_y={-size[1] / 2 - b[0][1]:.4f}",
        ]
        x += size[0] + 10.0
    cmd += ["-o", str(out)]
    proc = _run(cmd, env=env)
    # CuraEngine's stderr lists every resolved setting (global, then per extruder): kept for tests
    # that need the settings Cura's frontend would have (tests/integrations, the Cura plugin).
    out.with_suffix(".stderr.txt").write_text(proc.stderr, encoding="utf-8")
    if not out.is_file() or out.stat().st_size == 0:
        raise SlicerError(f"CuraEngine wrote no G-code to {out}")
    return out


def prusa_version() -> str:
    """``PrusaSlicer-2.5.0+...`` as printed by ``prusa-slicer --help``."""
    proc = subprocess.run(["prusa-slicer", "--help"], capture_output=True, text=True, timeout=60)
    m = re.search(r"PrusaSlicer-\S+", proc.stdout)
    return m.group(0) if m else "PrusaSlicer (unknown version)"


def cura_version() -> str:
    """``Cura_SteamEngine version 4.13.0`` as printed by ``CuraEngine help``."""
    proc = subprocess.run(["CuraEngine", "help"], capture_output=True, text=True, timeout=60)
    m = re.search(r"Cura_SteamEngine version \S+", proc.stdout + proc.stderr)
    return m.group(0) if m else "CuraEngine (unknown version)"


GYROID_BRACKET: dict[str, str] = {
    **PRUSA_MIXED, "top_solid_layers": "3", "bottom_solid_layers": "3", "fill_pattern": "gyroid"
}
"""The preset of :func:`gyroid_bracket`: the mixed preset's 20 % as gyroid, 3 top / 3 bottom skins."""


def gyroid_bracket(folder: Path, case_text: str) -> tuple[Path, Path]:
    """The 4 mm L-bracket sliced by PrusaSlicer 2.5 with :data:`GYROID_BRACKET` (``bench_sparse.py``'s
    slice) as ``folder/bracket.gcode`` beside ``bracket.stl``, and ``case_text`` written beside it:
    (G-code, case)."""
    stl = write_stl(bracket_mesh(thickness=4.0), folder / "bracket.stl")
    src = slice_prusa(stl, folder / "bracket.gcode", **GYROID_BRACKET)
    case = folder / "case.toml"
    case.write_text(case_text, encoding="utf-8")
    return src, case
