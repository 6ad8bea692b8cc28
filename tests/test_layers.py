"""The packages stack in pipeline order, and every import (also those inside functions) goes down.

:data:`STACK` is the order, lowest first; a module may import its own level or any level below.
Besides that rule, three more say what the layout is for: the core never imports the application
(``loadpath.plugin``), no engine imports another (what they share is ``loadpath.engines.finish``),
and the pipeline reaches an engine only through the registry (``loadpath.engines``), never an
engine's own modules.  The walk reads the sources with :mod:`ast` (nothing is imported), so an
import in a function that no test calls is checked too.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ROOTS = {
    "core": "loadpath",
    "plugin": "loadpath.plugin",
    "prusaslicer_postproc": "loadpath.prusaslicer_postproc",
}

STACK: tuple[tuple[str, ...], ...] = (
    ("loadpath", "loadpath._typing", "loadpath.errors", "loadpath.tolerances", "loadpath.budget", "loadpath.jit",
     "loadpath.areal"),
    # the contracts between stages: stress field, engine input/output, body, engine registry,
    # toolpath options, metrics of paths in a field
    (
        "loadpath.field",
        "loadpath.toolpath",
        "loadpath.body",
        "loadpath.engines",
        "loadpath.engines.registry",
        "loadpath.options",
        "loadpath.metrics",
        "loadpath.density",
    ),
    ("loadpath.gcode",),  # the reader, and its binary container (loadpath.gcode.bgcode)
    ("loadpath.geometry",),
    ("loadpath.mesh",),
    ("loadpath.loadcase",),
    ("loadpath.fea",),
    ("loadpath.stiffness",),
    ("loadpath.engines.finish",),
    ("loadpath.engines.swarm", "loadpath.engines.streamlines", "loadpath.engines.levelset"),
    ("loadpath.splice",),
    ("loadpath.pipeline",),
    ("loadpath.report", "loadpath.verdict"),  # what a run says: its report and its one-line verdict
    ("loadpath.plugin", "loadpath.prusaslicer_postproc", "loadpath.examples"),
)
ENGINES = ("loadpath.engines.swarm", "loadpath.engines.streamlines", "loadpath.engines.levelset")
APPLICATION = ("loadpath.plugin", "loadpath.prusaslicer_postproc", "loadpath.examples")


def _within(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _unit(module: str) -> str:
    """The longest :data:`STACK` entry ``module`` belongs to."""
    best = ""
    for level in STACK:
        for name in level:
            if _within(module, name) and len(name) > len(best):
                best = name
    if not best:
        raise AssertionError(f"{module} is in no level of STACK; add it where it belongs")
    return best


def _level(module: str) -> int:
    unit = _unit(module)
    return next(i for i, level in enumerate(STACK) if unit in level)


def module_name(path: Path) -> str:
    """``core/engines/swarm/step.py`` -> ``loadpath.engines.swarm.step``."""
    for folder, package in ROOTS.items():
        try:
            rel = path.relative_to(REPO / folder)
        except ValueError:
            continue
        parts = list(rel.with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        return ".".join([package, *parts])
    raise ValueError(path)


def imports(source: str, module: str, is_package: bool, known: set[str]) -> set[str]:
    """Every ``loadpath`` module ``source`` imports, wherever the import statement is."""
    out: set[str] = set()
    base = module if is_package else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if _within(a.name, "loadpath"))
        elif isinstance(node, ast.ImportFrom):
            target = node.module or ""
            if node.level:  # relative: from . import x / from .x import y
                up = base.split(".")[: len(base.split(".")) - (node.level - 1)]
                target = ".".join(up + ([node.module] if node.module else []))
            if not _within(target, "loadpath"):
                continue
            for a in node.names:  # "from loadpath import engines" imports the module loadpath.engines
                sub = f"{target}.{a.name}"
                out.add(sub if sub in known else target)
    return out


def violations(edges: dict[str, set[str]]) -> list[str]:
    """Broken rules of ``edges`` (module -> the loadpath modules it imports), one line each."""
    bad = []
    for name, targets in sorted(edges.items()):
        for target in sorted(targets):
            if _within(name, target):  # a package face importing its own parts, or itself
                continue
            core = not any(_within(name, a) for a in APPLICATION)
            if core and any(_within(target, a) for a in APPLICATION):
                bad.append(f"{name} imports {target}: the core imports the application")
            mine = next((e for e in ENGINES if _within(name, e)), None)
            theirs = next((e for e in ENGINES if _within(target, e)), None)
            if mine and theirs and mine != theirs:
                bad.append(f"{name} imports {target}: one engine imports another")
            if _within(name, "loadpath.pipeline") and theirs:
                bad.append(f"{name} imports {target}: the pipeline reaches into an engine (use the registry)")
            if _level(target) > _level(name):
                bad.append(f"{name} imports {target}: {_unit(target)} is above {_unit(name)}")
    return bad


@functools.cache
def _sources() -> tuple[tuple[str, str, bool], ...]:
    out = []
    for folder in ROOTS:
        for path in sorted((REPO / folder).rglob("*.py")):
            out.append((module_name(path), path.read_text(encoding="utf-8"), path.name == "__init__.py"))
    return tuple(out)


@functools.cache
def _tree_edges() -> tuple[tuple[str, frozenset[str]], ...]:
    known = {name for name, _, _ in _sources()}
    return tuple((name, frozenset(imports(src, name, pkg, known))) for name, src, pkg in _sources())


def _edges() -> dict[str, set[str]]:
    return {name: set(targets) for name, targets in _tree_edges()}


def test_every_import_goes_down_the_stack():
    edges = _edges()
    assert len(edges) > 100 and "loadpath.splice.splicer" in edges and "loadpath.engines.finish.ends" in edges
    assert (
        "loadpath.engines.finish.ends" in edges["loadpath.engines.streamlines.engine"]
    )  # the walk sees imports
    assert violations(edges) == []


@pytest.mark.parametrize(
    ("name", "source", "rule"),
    [
        (
            "loadpath.gcode.parse",
            "from loadpath.plugin import settings\n",
            "the core imports the application",
        ),
        (
            "loadpath.engines.streamlines.engine",
            "def f():\n    from loadpath.engines.swarm.ends import extend_ends\n",
            "one engine imports another",
        ),
        (
            "loadpath.pipeline.paths",
            "import loadpath.engines.swarm.warmup\n",
            "the pipeline reaches into an engine",
        ),
        (
            "loadpath.mesh.outline",
            "from loadpath.loadcase import Body\n",
            "loadpath.loadcase is above loadpath.mesh",
        ),
        ("loadpath.gcode.model", "from ..splice import splicer\n", "loadpath.splice is above loadpath.gcode"),
    ],
)
def test_each_rule_catches_its_import(name, source, rule):
    edges = _edges()
    edges[name] = imports(source, name, False, set(edges))
    found = violations(edges)
    assert any(rule in line and line.startswith(name) for line in found), found
