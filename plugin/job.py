"""One job: a G-code file and a load case in, the processed file (and a report) out, safely.

This is what every front end calls (``loadpath run``, ``loadpath demo``, the PrusaSlicer hook, the
Cura plugin through the command line, batch and serve)::

    from loadpath.plugin.job import JobRequest, run_job
    result = run_job(JobRequest(Path("part.gcode"), Path("case.toml"), cli={"engine": "swarm"}))
    result.output, result.warnings

Guarantees (interface.md, "Exit status"): the output is written to a temporary file in the target
folder and renamed over the target only when everything succeeded, so the input (and an existing
output) is never left half-written; on any failure the input is untouched.  With
``on_failure = "keep"`` a failure becomes a warning and the slicer's G-code is kept (copied to the
output when the output is another file).  Binary G-code is written back as binary G-code.
"""

from __future__ import annotations

import os
import secrets
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from loadpath.density import DensityOptions
from loadpath.errors import LoadpathError, SettingsError
from loadpath.plugin import settings as settings_mod

__all__ = ["JobRequest", "JobResult", "run_job", "default_output", "write_atomic", "infer_cura_filament"]


@dataclass(frozen=True)
class JobRequest:
    """What to do.

    Attributes
    ----------
    input : Path
        The slicer's G-code (text or binary).
    loadcase : Path
        The load case TOML.
    output : Path or None
        Default: next to the input as ``IN.loadpath.gcode`` (``.bgcode`` for binary files).
    in_place : bool
        Rewrite the input itself (atomically).
    report : Path or None
        Folder for the HTML report and ``metrics.json``.
    cli : mapping
        Settings given on the command line (field -> value).
    slicer_settings : Path or None
        The slicer's settings as JSON (Cura's keys; the Cura plugin writes it).
    env : mapping or None
        Environment to read ``SLIC3R_*`` from (the PrusaSlicer hook passes ``os.environ``).
    analyze : callable or None
        Replaces :func:`loadpath.fea.analyze` (see :func:`loadpath.pipeline.run`); the local service
        passes one that caches FEA results.
    """

    input: Path
    loadcase: Path
    output: Path | None = None
    in_place: bool = False
    report: Path | None = None
    cli: Mapping[str, Any] = field(default_factory=dict)
    slicer_settings: Path | None = None
    env: Mapping[str, str] | None = None
    analyze: Callable[..., Any] | None = None


@dataclass
class JobResult:
    """What happened.

    Attributes
    ----------
    output : Path
        Where the result is (the input itself when in place).
    written : bool
        A file was written.
    changed : bool
        Infill was replaced (False: the slicer's G-code came back unchanged).
    warnings : list of str
    error : str or None
        The failure that ``on_failure = "keep"`` turned into a warning.
    pipeline : PipelineResult or None
    settings : Settings or None
    times : dict of str -> float, s
        Per stage: parse, geometry, loadcase, fea, paths, splice, check, write, report.
    report : Path or None
        The report's HTML page.
    """

    output: Path
    written: bool = False
    changed: bool = False
    warnings: list[str] = field(default_factory=list)
    error: str | None = None
    pipeline: Any = None
    settings: Any = None
    times: dict[str, float] = field(default_factory=dict)
    report: Path | None = None


def default_output(path: Path) -> Path:
    """``part.gcode`` -> ``part.loadpath.gcode`` (``part.bgcode`` -> ``part.loadpath.bgcode``)."""
    suffix = path.suffix if path.suffix else ".gcode"
    return path.with_name(f"{path.stem}.loadpath{suffix}")


def write_atomic(path: Path, data: bytes, mode_like: Path | None = None) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename.

    The file keeps the permission bits of ``path`` if it exists, else takes those of ``mode_like``
    (the input G-code) if given, else the umask default (``0o666 & ~umask``, what the user's own
    tools would create); never ``mkstemp``'s 0600.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    mode = next(
        (Path(p).stat().st_mode & 0o7777 for p in (path, mode_like) if p is not None and Path(p).is_file()),
        None,
    )
    try:
        fd, tmp = _create_temp(folder, path.name)
    except OSError as exc:
        raise SettingsError(
            f"cannot write into {str(folder)!r}: {exc.strerror or exc}; choose another output folder with -o"
        ) from exc
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise SettingsError(
            f"cannot write {str(path)!r}: {exc.strerror or exc}; check the folder's permissions "
            "and free space"
        ) from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _create_temp(folder: Path, name: str) -> tuple[int, str]:
    """Create a hidden file next to the target, mode 0o666 so the kernel applies the umask (not 0600)."""
    for _ in range(100):
        tmp = str(folder / f".{name}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary name next to {name!r} in {str(folder)!r}")


def infer_cura_filament(program, geo) -> float | None:
    """Filament diameter from the solid infill of a file without settings (Cura), mm, or None.

    Solid infill tiles its region: its flow width equals its line spacing, so
    ``E * pi d^2 / 4 = pitch * height * length`` gives ``d``.  Snapped to 1.75 or 2.85 mm within 5 %.
    """
    import numpy as np

    ds = []
    for obj in geo.objects:
        for lg in obj.layers:
            for isl in lg.islands:
                for b in isl.blocks:
                    if b.kind in ("solid", "bottom", "top") and b.length > 20 and b.pitch > 0:
                        blk = program.block(b.block_index)
                        if blk.e > 0:
                            area = b.pitch * b.height * blk.length / blk.e
                            ds.append(float(np.sqrt(4 * area / np.pi)))
    if not ds:
        return None
    d = float(np.median(ds))
    for std in (1.75, 2.85):
        if abs(d - std) <= 0.05 * std:
            return std
    return d


def run_job(request: JobRequest, progress: Callable[[str, int, int], None] | None = None) -> JobResult:
    """Run one job (see the module docstring).

    Raises
    ------
    LoadpathError
        On failure, unless ``on_failure`` is ``"keep"`` (then the result carries the error).
    """
    inp = Path(request.input)
    out = inp if request.in_place else Path(request.output) if request.output else default_output(inp)
    result = JobResult(output=out)
    on_failure = str(request.cli.get("on_failure") or "fail")
    try:
        return _run(request, inp, out, result, progress)
    except LoadpathError as exc:
        error = str(exc)
    except MemoryError:
        error = "out of memory; close other programs or process a smaller file"
    except Exception as exc:  # a bug: still one line, and the input stays untouched
        error = (
            f"internal error ({type(exc).__name__}: {' '.join(str(exc).split())}); the input is untouched; "
            "please report this with the G-code and load case"
        )
    if on_failure != "keep" and (result.settings is None or result.settings.on_failure != "keep"):
        raise LoadpathError(error)
    result.error = error
    result.warnings.append(f"kept the slicer's G-code unchanged: {error}")
    if out != inp and inp.is_file():
        write_atomic(out, inp.read_bytes(), mode_like=inp)
        result.written = True
    return result


def _run(
    request: JobRequest,
    inp: Path,
    out: Path,
    result: JobResult,
    progress: Callable[[str, int, int], None] | None,
) -> JobResult:
    from loadpath import gcode, loadcase, pipeline
    from loadpath.pipeline.paths import default_workers

    times = result.times
    t = time.perf_counter()
    if not inp.is_file():
        raise SettingsError(f"G-code file {str(inp)!r} does not exist; check the path")
    lc = loadcase.read(request.loadcase)
    program, container = gcode.read_container(inp)
    cura = settings_mod.read_cura_settings(request.slicer_settings) if request.slicer_settings else None
    s = settings_mod.resolve(
        program, env=request.env, cura_settings=cura, toolpath=lc.toolpath, cli=request.cli
    )
    result.settings = s
    times["parse"] = time.perf_counter() - t

    if s.source("filament_diameter") == "default" and program.dialect.family == "cura":
        from loadpath import geometry

        d = infer_cura_filament(program, geometry.layer_geometry(program))
        if d is not None:
            s = s.with_values({"filament_diameter": d}, "inferred from the G-code")
            result.settings = s
    params = {"K": s.K} if s.engine == "swarm" else {}
    opts = pipeline.PipelineOptions(
        engine=s.engine,
        engine_params=params,
        pitch=s.pitch,
        principal=s.principal,
        cross_angle=s.cross_angle,
        replace=tuple(s.replace),
        stagger=s.stagger,
        workers=s.jobs or default_workers(),
        check=s.check,
        density=DensityOptions(
            s.density, s.density_exponent, fill=s.sparse_fill, max_pitch=s.density_max_pitch
        ),
    )
    pres = pipeline.run(
        program, lc, opts, settings_mod.splice_options(s), progress=progress, cura_settings=cura,
        analyze=request.analyze,
    )
    result.pipeline = pres
    times.update(pres.times)
    result.warnings.extend(pres.warnings)
    result.changed = pres.changed

    t = time.perf_counter()
    data = (
        gcode.encode_like(container, pres.data)
        if pres.changed
        else program.to_bytes()
        if container is None
        else inp.read_bytes()
    )
    if pres.changed or out != inp:
        write_atomic(out, data, mode_like=inp)
        result.written = True
    times["write"] = time.perf_counter() - t
    if request.report is not None:
        from loadpath.report import write_report

        t = time.perf_counter()
        result.report = write_report(Path(request.report), pres, s, times, source=inp.name)
        times["report"] = time.perf_counter() - t
    return result
