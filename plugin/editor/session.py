"""What the editor's page asks for, answered with loadpath's own code (thin over core/).

The page holds the load case in the form the TOML file has (``{"version": 1, "supports": [...],
...}``) and sends it whole with every request; this module validates it with
:func:`loadpath.loadcase.from_dict`, evaluates the selectors with
:func:`loadpath.loadcase.resolve_body` (the code ``inspect`` and ``run`` use), and answers the picked
geometry, the errors in ``run``'s words (each tied to the support or load at fault), the stress
field and a preview of the new paths, and the TOML that "Save" writes.
"""

from __future__ import annotations

import re
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from loadpath import loadcase as lcmod
from loadpath.errors import LoadCaseError, LoadpathError
from loadpath.plugin.editor.part import EditorPart, layer_view

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["EditorSession", "case_to_dict", "materials", "toolpath_schema"]

_ITEM = re.compile(r"\b(supports|loads)\[(\d+)\]")
_GRID = 46  # stress samples across the part's larger side


def case_to_dict(lc: lcmod.LoadCase) -> dict[str, Any]:
    """Return the TOML-table form of a load case (what the page edits); read back from :func:`to_toml`."""
    return tomllib.loads(lcmod.to_toml(lc))


def materials() -> list[dict[str, Any]]:
    """Material cards the page offers: the interface default and the printed cards of the stiffness model.

    The stress analysis is isotropic: a printed card gives its along-filament modulus and major
    Poisson's ratio (``E1``, ``nu12``).
    """
    from loadpath.fea.orthotropic import ABS_PRINTED, PLA_PRINTED

    cards = [
        {
            "name": "PLA (interface default)",
            "youngs_modulus": lcmod.PLA.youngs_modulus,
            "poissons_ratio": lcmod.PLA.poissons_ratio,
            "source": "docs/interface.md",
        }
    ]
    for m in (PLA_PRINTED, ABS_PRINTED):
        cards.append({"name": m.name, "youngs_modulus": m.E1, "poissons_ratio": m.nu12, "source": m.source})
    return cards


def toolpath_schema() -> list[dict[str, Any]]:
    """Return the settings a ``[toolpath]`` table may hold, with their help texts (the settings schema)."""
    from loadpath.plugin.settings import SCHEMA, field_json

    return [{"name": f.name, **field_json(f)} for f in SCHEMA if f.toolpath]


def _item_of(message: str) -> str | None:
    m = _ITEM.search(message)
    return f"{m.group(1)}/{m.group(2)}" if m else None


def _lines_json(g: Any) -> list[list[list[float]]]:
    if g is None or g.is_empty:
        return []
    return [np.round(np.asarray(ln.coords)[:, :2], 4).tolist() for ln in getattr(g, "geoms", [g])]


@dataclass
class EditorSession:
    """One editor: the part, where the case is saved, and a work folder for previews.

    Attributes
    ----------
    part : EditorPart
    save_path : Path
        The one file "Save" writes.
    initial : LoadCase or None
        The case opened with ``--loadcase`` (when the file exists).
    """

    part: EditorPart
    save_path: Path
    initial: lcmod.LoadCase | None = None
    _work: tempfile.TemporaryDirectory = field(
        default_factory=lambda: tempfile.TemporaryDirectory(prefix="loadpath-edit-")
    )
    _solving: threading.Lock = field(default_factory=threading.Lock)
    _job: dict[str, Any] | None = None
    _job_id: int = 0

    def __post_init__(self) -> None:
        frame = self.initial.frame if self.initial is not None else self.part.frame
        self.view = layer_view(self.part, frame)
        self.view_frame = frame

    def close(self) -> None:
        """Remove the work folder."""
        self._work.cleanup()

    # ------------------------------------------------------------------------------------ answers
    def start(self) -> dict[str, Any]:
        """GET /api/start: the part, the case to show, the choices and help texts."""
        case = (
            case_to_dict(self.initial)
            if self.initial is not None
            else {
                "version": 1,
                "frame": self.part.frame,
                "supports": [],
                "loads": [],
                "material": {
                    "youngs_modulus": lcmod.PLA.youngs_modulus,
                    "poissons_ratio": lcmod.PLA.poissons_ratio,
                },
            }
        )
        return {
            "ok": True,
            "part": {"name": self.part.path.name, "kind": self.part.kind, **self.view},
            "frame": self.view_frame,
            "case": case,
            "save_path": str(self.save_path),
            "materials": materials(),
            "toolpath": toolpath_schema(),
        }

    def _case(self, data: Any) -> lcmod.LoadCase:
        if not isinstance(data, dict):
            raise LoadCaseError("the load case must be a table")
        data = {k: v for k, v in data.items() if not (k in ("supports", "loads") and v == [])}
        return lcmod.from_dict(data, source=self.save_path.name)

    def _resolved(self, lc: lcmod.LoadCase) -> list[lcmod.ResolvedBody]:
        bodies = list(self.part.bodies)
        if lc.object is not None:
            bodies = [b for b in bodies if b.name == lc.object]
            if not bodies:
                lcmod.resolve(lc, self.part.bodies)  # raises run's message naming the objects found
        return [lcmod.resolve_body(lc, b, check=False) for b in bodies]

    def resolve(self, data: Any) -> dict[str, Any]:
        """POST /api/resolve: what each selector picks, the errors, and the TOML "Save" would write."""
        data = data if isinstance(data, dict) else {}
        partial = {**data, "supports": data.get("supports") or [], "loads": data.get("loads") or []}
        try:
            lc = self._case(partial)
            rbs = self._resolved(lc)
        except LoadCaseError as exc:
            return {
                "ok": False,
                "errors": [{"item": _item_of(str(exc)), "message": str(exc)}],
                "selections": [],
            }
        index = {s.name: f"supports/{i}" for i, s in enumerate(lc.supports)}
        index.update({ld.name: f"loads/{i}" for i, ld in enumerate(lc.loads)})
        errors = []
        for rb in rbs:
            for sel, msg in lcmod.empty_selections(rb):
                errors.append({"item": index[sel.name], "message": msg})
        if not lc.supports:
            errors.append(
                {
                    "item": "supports",
                    "message": (
                        f"{lc.source}: missing section [[supports]]; the part must be held: click an edge "
                        "or a hole and choose a support"
                    ),
                }
            )
        if not lc.loads:
            errors.append(
                {
                    "item": "loads",
                    "message": (
                        f"{lc.source}: missing section [[loads]]; add at least one load: "
                        "click a hole or an edge"
                    ),
                }
            )
        sels = []
        for rb in rbs:
            lo, hi = rb.body.bounds
            pad = 0.01 * float(np.max(hi - lo)) + 0.5  # open sides of a box drawn just past the part
            for sel in rb.selections:
                box = None
                if sel.lower is not None:
                    blo = np.maximum(sel.lower[:2], lo[:2] - pad)
                    bhi = np.minimum(sel.upper[:2], hi[:2] + pad)
                    box = np.round(np.concatenate([blo, bhi]), 4).tolist()
                sels.append(
                    {
                        "item": index[sel.name],
                        "name": sel.name,
                        "object": rb.name,
                        "role": sel.role,
                        "picked": lcmod.describe_pick(sel, rb.analysis),
                        "box": box,
                        "layers": [_lines_json(sel.lines_at(L["z"])) for L in self.view["layers"]],
                    }
                )
        picks = {s["name"]: s["picked"] for s in sels}
        ok = not errors
        return {
            "ok": ok,
            "errors": errors,
            "selections": sels,
            "analysis": {rb.name: f"{rb.analysis} ({rb.reason})" for rb in rbs},
            "toml": lcmod.to_toml(lc, picks, self._header()) if lc.supports and lc.loads else None,
        }

    def _header(self) -> str:
        return f"load case made with `loadpath edit` on {self.part.path.name}"

    def save(self, data: Any) -> dict[str, Any]:
        """POST /api/save: write the TOML to the save path (atomically) when the case resolves."""
        answer = self.resolve(data)
        if not answer["ok"]:
            return {**answer, "saved": None}
        from loadpath.plugin.job import write_atomic

        write_atomic(self.save_path, answer["toml"].encode("utf-8"))
        return {**answer, "saved": str(self.save_path)}

    def solve(self, data: Any, layer: int) -> dict[str, Any]:
        """Solve now: stress field of the shown layer, new paths there, predicted stiffness."""
        answer = self.resolve(data)
        if not answer["ok"]:
            return answer
        if not self._solving.acquire(blocking=False):
            return {**answer, "ok": False, "errors": [{"item": None, "message": "a solve is running; wait"}]}
        try:
            return self._solve_checked(answer, data, layer)
        finally:
            self._solving.release()

    def _solve_checked(self, answer: dict[str, Any], data: Any, layer: int) -> dict[str, Any]:
        try:
            return {**answer, **self._solve(self._case(data), layer)}
        except LoadpathError as exc:
            msg = str(exc)
            item = _item_of(msg) or ("supports" if "free to" in msg else None)
            return {**answer, "ok": False, "errors": [{"item": item, "message": msg}]}
        except Exception as exc:  # a bug: one line to the page
            msg = f"internal error ({type(exc).__name__}: {' '.join(str(exc).split())}); please report it"
            return {**answer, "ok": False, "errors": [{"item": None, "message": msg}]}

    def solve_start(self, data: Any, layer: int) -> dict[str, Any]:
        """POST /api/solve: check the case and start solving in the background.

        A G-code solve runs the whole pipeline and can take minutes; the page then asks
        :meth:`solve_result` once a second.
        """
        answer = self.resolve(data)
        if not answer["ok"]:
            return answer
        if not self._solving.acquire(blocking=False):
            return {**answer, "ok": False, "errors": [{"item": None, "message": "a solve is running; wait"}]}
        self._job_id += 1
        job = {"id": self._job_id, "result": None, "t0": time.monotonic()}
        self._job = job

        def work() -> None:
            try:
                job["result"] = self._solve_checked(answer, data, layer)
            finally:
                self._solving.release()

        threading.Thread(target=work, name="loadpath-edit-solve", daemon=True).start()
        return {**answer, "running": True, "job": job["id"]}

    def solve_result(self, job_id: Any) -> dict[str, Any]:
        """POST /api/solve-result: the answer of a started solve, or ``running`` and the seconds so far."""
        job = self._job
        if job is None or job["id"] != job_id:
            return {"ok": False, "errors": [{"item": None, "message": f"no solve {job_id!r}; press Solve"}]}
        if job["result"] is None:
            return {"ok": True, "running": True, "job": job_id, "seconds": time.monotonic() - job["t0"]}
        return {**job["result"], "running": False, "job": job_id}

    def _solve(self, lc: lcmod.LoadCase, layer: int) -> dict[str, Any]:
        from loadpath.plugin.editor.preview import gcode_preview, stl_preview, stress_grid

        layers = self.view["layers"]
        if not 0 <= layer < len(layers):
            raise LoadCaseError(f"layer {layer} is not shown; choose one of 0..{len(layers) - 1}")
        shown = layers[layer]
        principal = lc.toolpath.principal if lc.toolpath.principal not in (None, "alternate") else "max_abs"
        fields, analyses = [], {}
        for rb in self._resolved(lc):
            if rb.body.slab_at(shown["z"]) is None:
                continue
            analysis, grid = stress_grid(rb, shown["z"], principal, _GRID)
            analyses[rb.name] = (rb, analysis)
            fields.append(grid)
        if self.part.kind == "gcode":
            work = Path(self._work.name)
            case_file = work / "case.toml"
            case_file.write_text(lcmod.to_toml(lc), encoding="utf-8")
            preview = gcode_preview(self.part, case_file, lc, shown["z0"], shown["z1"], work)
        else:
            rb, analysis = next(iter(analyses.values()))
            preview = stl_preview(rb, analysis, lc, shown["z"])
        return {"stress": fields, "preview": preview}
