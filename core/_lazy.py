"""Modules imported on first use: :func:`lazy` (start-up time of ``loadpath run``, issue 17).

A run that finds its stress analysis and paths in the cache (:mod:`loadpath.cache`) never solves,
so it need not import scipy's sparse solvers (a third of a second of start-up on an idle machine,
seconds on a loaded one).  ``sp = lazy("scipy.sparse")`` at module level behaves like
``import scipy.sparse as sp`` but imports the module the first time an attribute is read.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

__all__ = ["lazy"]


class _Lazy:
    """Stands for a module until an attribute of it is read (then imports it)."""

    def __init__(self, name: str) -> None:
        self._lazy_name = name
        self._lazy_module: ModuleType | None = None

    def __getattr__(self, attr: str) -> Any:
        if self._lazy_module is None:
            self._lazy_module = importlib.import_module(self._lazy_name)
        return getattr(self._lazy_module, attr)

    def __repr__(self) -> str:
        return f"<lazy module {self._lazy_name!r}>"


def lazy(name: str) -> Any:
    """Return a stand-in for module ``name`` that imports it on first attribute access."""
    return _Lazy(name)
