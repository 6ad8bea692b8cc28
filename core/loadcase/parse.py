"""Read and validate the load-case TOML file (interface.md, version 1).

Every problem raises :class:`~loadpath.errors.LoadCaseError` with one line naming the file, the key
(as a path such as ``loads[0].force``), the bad value, what is expected and how to fix it.
Checks: TOML syntax, unknown keys, wrong types, missing sections, non-physical values
(``E <= 0``, Poisson's ratio outside ``(-1, 0.5)``, negative distances, zero loads).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from loadpath import options
from loadpath.errors import LoadCaseError, SettingsError
from loadpath.loadcase.model import (
    AXES,
    PLA,
    SIDES,
    BoxSelector,
    HoleSelector,
    Load,
    LoadCase,
    Material,
    Selector,
    SideSelector,
    Support,
    ToolpathOptions,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["read", "parse", "from_dict"]

_TOP_KEYS = ("version", "object", "frame", "material", "supports", "loads", "toolpath")
_MATERIAL_KEYS = ("youngs_modulus", "poissons_ratio", "printed")
E_PLAUSIBLE = (5.0, 100_000.0)
"""Young's moduli a printed part may have, MPa: from the softest TPU (85A: about 10) to carbon-filled
nylon and PEEK (up to about 20 000), with room either side."""
_SUPPORT_KEYS = ("name", "where", "fix")
_LOAD_KEYS = ("name", "where", "force", "pressure")
MAX_FORCE_N = 1.0e8
"""Largest force component accepted, N (about 10,000 t: every printed part fails far below; larger
numbers, up to 1e308, overflow the FEA and read as an unsupported part)."""
MAX_PRESSURE_MPA = 1.0e6
"""Largest pressure accepted, MPa."""

_EXAMPLE_SUPPORT = '[[supports]] where = { side = "x_min", within = 5.0 } fix = ["x", "y", "z"]'
_EXAMPLE_LOAD = '[[loads]] where = { side = "x_max", within = 5.0 } force = [1000.0, 0.0, 0.0]'


def read(path: str | Path) -> LoadCase:
    """Read a load-case file.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    LoadCase

    Raises
    ------
    LoadCaseError
        The file cannot be read or is not a valid load case.
    """
    from loadpath.files import NotRegularError, read_regular

    p = Path(path)
    try:
        text = read_regular(p, limit=64 << 20).decode("utf-8")
    except NotRegularError as exc:
        raise LoadCaseError(f"load case {str(p)!r} {exc}; give the path of a .toml file") from None
    except FileNotFoundError:
        raise LoadCaseError(f"cannot read load case {str(p)!r}: it does not exist; check the path") from None
    except OSError as exc:
        raise LoadCaseError(
            f"cannot read load case {str(p)!r}: {exc.strerror or exc}; check the path"
        ) from exc
    except UnicodeDecodeError as exc:
        raise LoadCaseError(f"load case {str(p)!r} is not UTF-8 text; save it as UTF-8 TOML") from exc
    return parse(text, source=p.name)


def parse(text: str, source: str = "load case") -> LoadCase:
    """Parse load-case TOML text.

    Parameters
    ----------
    text : str
        TOML.
    source : str
        Name used in messages (the file name).

    Returns
    -------
    LoadCase
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise LoadCaseError(f"{source}: not valid TOML: {exc}; fix the syntax (see interface.md)") from exc
    except RecursionError:
        raise LoadCaseError(
            f"{source}: arrays or tables nested too deeply to read; a load case nests at most a few "
            "levels (see interface.md)") from None
    try:
        return from_dict(data, source=source)
    except RecursionError:
        raise LoadCaseError(f"{source}: values nested too deeply; see interface.md for the keys") from None


class _Ctx:
    """Builds messages that start with the source name."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, msg: str) -> LoadCaseError:
        return LoadCaseError(f"{self.source}: {msg}")

    def keys(self, table: Mapping[str, Any], allowed: tuple[str, ...], where: str) -> None:
        for key in table:
            if key not in allowed:
                raise self.fail(
                    f"unknown key {key!r} in {where}; expected one of {', '.join(allowed)} "
                    "(check the spelling)"
                )

    def table(self, value: Any, where: str) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self.fail(f"{where} = {value!r} must be a table (e.g. {where} = {{ ... }})")
        return value

    def number(self, value: Any, where: str, unit: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(f"{where} = {value!r} must be a number ({unit})")
        v = float(value)
        if not math.isfinite(v):
            raise self.fail(f"{where} = {value!r} must be a finite number ({unit})")
        return v

    def string(self, value: Any, where: str, choices: tuple[str, ...] | None = None) -> str:
        if not isinstance(value, str):
            hint = f"one of {', '.join(repr(c) for c in choices)}" if choices else "a string in quotes"
            raise self.fail(f"{where} = {value!r} must be {hint}")
        if choices is not None and value not in choices:
            raise self.fail(
                f"{where} = {value!r} is not valid; use one of {', '.join(repr(c) for c in choices)}"
            )
        return value

    def vector(self, value: Any, where: str, n: int, unit: str) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != n:
            raise self.fail(f"{where} = {value!r} must be a list of {n} numbers ({unit})")
        return tuple(self.number(v, f"{where}[{i}]", unit) for i, v in enumerate(value))


def from_dict(data: Mapping[str, Any], source: str = "load case") -> LoadCase:
    """Validate a load case given as the dictionary TOML gives.

    Parameters
    ----------
    data : mapping
        Parsed TOML.
    source : str
        Name used in messages.

    Returns
    -------
    LoadCase
    """
    c = _Ctx(source)
    c.keys(data, _TOP_KEYS, "the top level")
    if "version" not in data:
        raise c.fail("missing key 'version'; add version = 1 at the top of the file")
    version = data["version"]
    if isinstance(version, bool) or not isinstance(version, int):
        raise c.fail(f"version = {version!r} must be the integer 1")
    if version != 1:
        raise c.fail(f"version = {version} is not supported; this loadpath reads load-case version 1")

    obj = data.get("object")
    if obj is not None:
        obj = c.string(obj, "object")
        if not obj.strip():
            raise c.fail(
                "object = '' is empty; give the object's name as the slicer wrote it, or leave it out"
            )
    frame = c.string(data.get("frame", "bed"), "frame", ("bed", "part"))

    material = _material(c, data.get("material"))

    if "supports" not in data:
        raise c.fail(f"missing section [[supports]]; the part must be held, e.g. {_EXAMPLE_SUPPORT}")
    if "loads" not in data:
        raise c.fail(f"missing section [[loads]]; add at least one load, e.g. {_EXAMPLE_LOAD}")
    supports = tuple(_support(c, s, i) for i, s in enumerate(_array(c, data["supports"], "supports")))
    loads = tuple(_load(c, s, i) for i, s in enumerate(_array(c, data["loads"], "loads")))
    _unique_names(c, supports, loads)
    toolpath = _toolpath(c, data.get("toolpath"))
    return LoadCase(
        version=1,
        object=obj,
        frame=frame,
        material=material,
        supports=supports,
        loads=loads,
        toolpath=toolpath,
        source=source,
    )


def _array(c: _Ctx, value: Any, name: str) -> list[Mapping[str, Any]]:
    if isinstance(value, Mapping):
        raise c.fail(f"[{name}] must be an array of tables: write [[{name}]] (double brackets)")
    if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
        raise c.fail(f"{name} = {value!r} must be an array of tables written as [[{name}]]")
    if not value:
        raise c.fail(f"{name} is empty; add at least one [[{name}]] section")
    return value


def _material(c: _Ctx, value: Any) -> Material:
    if value is None:
        return PLA
    t = c.table(value, "material")
    c.keys(t, _MATERIAL_KEYS, "[material]")
    e = c.number(t.get("youngs_modulus", PLA.youngs_modulus), "material.youngs_modulus", "MPa")
    nu = c.number(t.get("poissons_ratio", PLA.poissons_ratio), "material.poissons_ratio", "dimensionless")
    if not e > 0:
        raise c.fail(f"material.youngs_modulus = {e} must be > 0 MPa (PLA: 3500)")
    if not E_PLAUSIBLE[0] <= e <= E_PLAUSIBLE[1]:  # 3.5 for PLA is GPa written where MPa is asked
        raise c.fail(
            f"material.youngs_modulus = {e:g} MPa is outside what printers print ({E_PLAUSIBLE[0]:g} to "
            f"{E_PLAUSIBLE[1]:g} MPa: a soft TPU about 10, PLA 3500); give it in MPa"
            + (f" ({e:g} GPa is {e * 1000:g} MPa)" if e < E_PLAUSIBLE[0] else "")
        )
    if not -1.0 < nu < 0.5:
        raise c.fail(f"material.poissons_ratio = {nu} must lie in (-1, 0.5) (PLA: 0.35)")
    printed = None
    if "printed" in t:
        printed = c.string(t["printed"], "material.printed").strip().lower()
        if printed not in ("pla", "petg", "abs"):
            raise c.fail(f'material.printed = "{printed}" is not a card; use "pla", "petg" or "abs"')
    return Material(e, nu, printed)


def _name(c: _Ctx, t: Mapping[str, Any], where: str, default: str) -> str:
    if "name" not in t:
        return default
    name = c.string(t["name"], f"{where}.name")
    if not name.strip():
        raise c.fail(f"{where}.name is empty; give it a name or leave the key out")
    return name


def _support(c: _Ctx, t: Mapping[str, Any], i: int) -> Support:
    where = f"supports[{i}]"
    c.keys(t, _SUPPORT_KEYS, where)
    name = _name(c, t, where, f"support {i + 1}")
    label = f"{where} ({name!r})"
    if "where" not in t:
        raise c.fail(f"{label} has no 'where'; add e.g. where = {{ side = \"x_min\", within = 5.0 }}")
    sel = _selector(c, t["where"], f"{label}.where")
    if "fix" not in t:
        raise c.fail(f'{label} has no \'fix\'; add e.g. fix = ["x", "y", "z"]')
    fix = t["fix"]
    if not isinstance(fix, list) or not fix:
        raise c.fail(f'{label}.fix = {fix!r} must be a non-empty list of "x", "y", "z"')
    axes = []
    for a in fix:
        if a not in AXES:
            raise c.fail(f'{label}.fix contains {a!r}; use any of "x", "y", "z"')
        if a in axes:
            raise c.fail(f"{label}.fix lists {a!r} twice; list each direction once")
        axes.append(a)
    return Support(name=name, where=sel, fix=tuple(sorted(axes, key=AXES.index)))


def _load(c: _Ctx, t: Mapping[str, Any], i: int) -> Load:
    where = f"loads[{i}]"
    c.keys(t, _LOAD_KEYS, where)
    name = _name(c, t, where, f"load {i + 1}")
    label = f"{where} ({name!r})"
    if "where" not in t:
        raise c.fail(f"{label} has no 'where'; add e.g. where = {{ side = \"x_max\", within = 5.0 }}")
    sel = _selector(c, t["where"], f"{label}.where")
    has_f, has_p = "force" in t, "pressure" in t
    if has_f == has_p:
        raise c.fail(
            f"{label} needs exactly one of force = [Fx, Fy, Fz] (N) or pressure = p (MPa)"
            + ("; it has both" if has_f else "")
        )
    if has_f:
        force = c.vector(t["force"], f"{label}.force", 3, "N")
        if all(f == 0.0 for f in force):
            raise c.fail(
                f"{label}.force = {list(force)} is zero; give the total force in N, e.g. [1000.0, 0.0, 0.0]"
            )
        if max(abs(f) for f in force) > MAX_FORCE_N:
            raise c.fail(
                f"{label}.force = {list(force)} N is beyond what a printed part can carry (at most "
                f"{MAX_FORCE_N:g} N per component); give the total force in N, e.g. [1000.0, 0.0, 0.0]")
        return Load(name=name, where=sel, force=(force[0], force[1], force[2]))
    p = c.number(t["pressure"], f"{label}.pressure", "MPa")
    if p == 0.0:
        raise c.fail(
            f"{label}.pressure = 0 is zero; give a non-zero pressure in MPa (positive pushes on the part)"
        )
    if abs(p) > MAX_PRESSURE_MPA:
        raise c.fail(f"{label}.pressure = {p!r} MPa is beyond what a printed part can carry (at most "
                     f"{MAX_PRESSURE_MPA:g} MPa); give the pressure in MPa")
    return Load(name=name, where=sel, pressure=p)


def _selector(c: _Ctx, value: Any, where: str) -> Selector:
    t = c.table(value, where)
    keys = set(t)
    if not keys:
        raise c.fail(
            f"{where} is empty; use {{ side = .., within = .. }}, box bounds, "
            "or { hole_near = .., radius = .. }"
        )
    if keys & {"side", "within"}:
        c.keys(t, ("side", "within"), where)
        if "side" not in t or "within" not in t:
            raise c.fail(f'{where} needs both side and within, e.g. {{ side = "x_min", within = 5.0 }}')
        side = c.string(t["side"], f"{where}.side", SIDES)
        within = c.number(t["within"], f"{where}.within", "mm")
        if within < 0:
            raise c.fail(f"{where}.within = {within} must be >= 0 mm")
        return SideSelector(side=side, within=within)
    if keys & {"hole_near", "radius"}:
        c.keys(t, ("hole_near", "radius"), where)
        if "hole_near" not in t:
            raise c.fail(
                f"{where} gives radius without hole_near, e.g. {{ hole_near = [75.0, 18.0], radius = 5.0 }}"
            )
        near = c.vector(t["hole_near"], f"{where}.hole_near", 2, "mm")
        if "radius" not in t:  # the nearest hole within its own diameter of the point
            return HoleSelector(near=(near[0], near[1]), radius=None)
        radius = c.number(t["radius"], f"{where}.radius", "mm")
        if radius <= 0:
            raise c.fail(f"{where}.radius = {radius} must be > 0 mm")
        return HoleSelector(near=(near[0], near[1]), radius=radius)
    c.keys(t, SIDES, where)
    lo = [-math.inf] * 3
    hi = [math.inf] * 3
    for key, v in t.items():
        x = c.number(v, f"{where}.{key}", "mm")
        (lo if key.endswith("min") else hi)[AXES.index(key[0])] = x
    for i, a in enumerate(AXES):
        if lo[i] > hi[i]:
            raise c.fail(f"{where}: {a}_min = {lo[i]} is above {a}_max = {hi[i]}; swap them")
    return BoxSelector(lower=(lo[0], lo[1], lo[2]), upper=(hi[0], hi[1], hi[2]))


def _unique_names(c: _Ctx, supports: tuple[Support, ...], loads: tuple[Load, ...]) -> None:
    seen: set[str] = set()
    for item in (*supports, *loads):
        if item.name in seen:
            raise c.fail(f"the name {item.name!r} is used twice; give each support and load its own name")
        seen.add(item.name)


def _toolpath(c: _Ctx, value: Any) -> ToolpathOptions:
    """Read the ``[toolpath]`` table: keys, choices and bounds are those of :mod:`loadpath.options`."""
    if value is None:
        return ToolpathOptions()
    t = c.table(value, "toolpath")
    c.keys(t, options.TABLE_KEYS, "[toolpath]")

    def bounded(name: str, x: Any) -> Any:
        try:
            return options.convert(options.field(name), x, f"toolpath.{name}")
        except SettingsError as exc:
            raise c.fail(str(exc)) from None

    engine = (
        c.string(t["engine"], "toolpath.engine", options.field("engine").choices) if "engine" in t else None
    )
    sparse_engine = (
        c.string(t["sparse_engine"], "toolpath.sparse_engine", options.field("sparse_engine").choices)
        if "sparse_engine" in t
        else None
    )
    pitch = None
    if "pitch" in t:
        pitch = c.number(t["pitch"], "toolpath.pitch", "mm")
        if pitch <= 0:
            raise c.fail(f"toolpath.pitch = {pitch} must be > 0 mm (e.g. 0.45)")
        pitch = bounded("pitch", pitch)
    k = None
    if "K" in t:
        k = c.number(t["K"], "toolpath.K", "dimensionless")
        if k < 0:
            raise c.fail(f"toolpath.K = {k} must be >= 0 (the paper uses 5)")
        k = bounded("K", k)
    principal = (
        c.string(t["principal"], "toolpath.principal", options.PRINCIPALS) if "principal" in t else None
    )
    replace = None
    if "replace" in t:
        r = t["replace"]
        if not isinstance(r, list) or not r:
            raise c.fail(
                f"toolpath.replace = {r!r} must be a non-empty list of "
                f"{', '.join(map(repr, options.REPLACE_KINDS))}"
            )
        for kind in r:
            c.string(kind, "toolpath.replace[]", options.REPLACE_KINDS)
        replace = tuple(dict.fromkeys(r))
    density = (
        c.string(t["density"], "toolpath.density", options.field("density").choices) if "density" in t else None
    )
    fill = None
    if "sparse_fill" in t:
        fill = c.number(t["sparse_fill"], "toolpath.sparse_fill", "fraction")
        if not 0.0 < fill <= 1.0:
            raise c.fail(f"toolpath.sparse_fill = {fill} must be a fraction in (0, 1] (e.g. 0.2 for 20 %)")
        fill = bounded("sparse_fill", fill)
    return ToolpathOptions(
        engine=engine,
        sparse_engine=sparse_engine,
        pitch=pitch,
        K=k,
        principal=principal,
        replace=replace,
        density=density,
        sparse_fill=fill,
    )
