"""The visual report of a run: one HTML page and ``metrics.json``.

:func:`write_report` writes into a folder:

``index.html``
    the run (input, engine, settings and where each came from, warnings, time per stage), then per
    distinct layer (one engine run, reused on the layers listed): the stress field, the slicer's
    paths and the new paths coloured by alignment with the followed principal stress, the
    histogram of spacing, and a table of metrics (beta, spacing variance, coverage, overlap, time,
    extruded volume before and after);
``metrics.json``
    the same numbers for scripts;
``layer-<n>.svg``, ``layer-<n>-detail.svg``
    each distinct layer's figure, and its close-up around the most stressed point, on their own
    (the README shows one).

Pure Python and numpy: no plotting library is needed.
"""

from __future__ import annotations

import html
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from loadpath import __version__
from loadpath.report.layers import LayerReport, layer_report
from loadpath.report.svg import colorbar
from loadpath.verdict import percent, signed

_OWN_FIGURE = re.compile(r"(?:layer-\d+(?:-detail)?|part-\d+)\.svg")
"""The names of the report's figures (:meth:`Report.write` removes an earlier report's others)."""

__all__ = ["write_report", "build_report", "Report", "LayerReport", "layer_report"]

_METRIC_ROWS = (
    ("beta", "alignment beta (paper Eq. 14)", "{:.4f}"),
    ("beta_curved", "beta where the field curves", "{:.4f}"),
    ("spacing_mean", "spacing mean / pitch", "{:.3f}"),
    ("spacing_var", "spacing variance (/ pitch^2)", "{:.4f}"),
    ("spacing_p5", "spacing 5th percentile / pitch", "{:.3f}"),
    ("coverage", "coverage", "{:.4f}"),
    ("overlap", "overlap", "{:.4f}"),
    ("n_paths", "paths", "{:.0f}"),
    ("length_mm", "printed length, mm", "{:.0f}"),
    ("travel_mm", "travel inside the blocks, mm", "{:.0f}"),
    ("crossings", "crossings", "{:.0f}"),
)


def _num(v: Any, f: str) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f.format(v)


@dataclass
class Report:
    """A report built in memory, before anything is written (so the run can still fail cleanly).

    Attributes
    ----------
    files : dict of str -> str
        File name -> text (``index.html``, ``metrics.json``, the SVG figures).
    warnings : list of str
        What could not be drawn or computed (the report never fails a run).
    """

    files: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    data: dict[str, Any] = field(default_factory=dict, repr=False)
    layers: list[LayerReport] = field(default_factory=list, repr=False)
    settings: Any = field(default=None, repr=False)

    analyses: dict[str, Any] = field(default_factory=dict, repr=False)

    def finish(self, verdict: Any = None) -> Report:
        """Render the part views, ``index.html`` and ``metrics.json`` with the verdict on top (in memory).

        A part view that cannot be drawn adds a warning to :attr:`warnings` (after the verdict
        counted them) and a note on the page.
        """
        from loadpath.report.part import part_figure

        self.data["verdict"] = verdict.as_dict() if verdict is not None else None
        change = (verdict.extra or {}).get("stiffness") if verdict is not None else None
        bodies = {b.name: b for b in change.bodies} if change is not None else {}
        views = []
        for k, (name, an) in enumerate(self.analyses.items()):
            try:
                svg = part_figure(an.resolved, bodies.get(name))
            except Exception as exc:  # a picture must not cost the user the G-code
                why = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
                self.warnings.append(f"report: no part view of {name!r} ({why})")
                views.append(f"<p>No part view of {html.escape(name)}: {html.escape(why)}</p>")
                continue
            self.files[f"part-{k + 1}.svg"] = svg
            views.append(svg)
        self.data["warnings"] = self.data.get("warnings", []) + [
            w for w in self.warnings if w not in self.data.get("warnings", [])
        ]
        self.files["metrics.json"] = json.dumps(self.data, indent=1, default=_json)
        self.files["index.html"] = _html(self.data, self.layers, self.settings, verdict, views)
        return self

    def write(self, directory: Path) -> Path:
        """Write the files into ``directory`` (created); returns ``index.html``.  Raises OSError."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        for name, text in self.files.items():
            (directory / name).write_text(text, encoding="utf-8")
        # an earlier report's figures this one does not have (a run with more layers) would sit
        # beside it as if they were its own: only files named as the report names its own go
        for old in directory.iterdir():
            if _OWN_FIGURE.fullmatch(old.name) and old.name not in self.files and old.is_file():
                old.unlink()
        return directory / "index.html"


def write_report(
    directory: Path, result, settings, times: dict[str, float], source: str = "", with_metrics: bool = True
) -> Path:
    """Build and write the report (see :func:`build_report`); returns ``index.html``."""
    return build_report(result, settings, times, source, with_metrics).finish().write(directory)


def build_report(
    result,
    settings,
    times: dict[str, float],
    source: str = "",
    with_metrics: bool = True,
    printability: dict | None = None,
) -> Report:
    """Build the report of a pipeline result in memory (see the module docstring).

    Parameters
    ----------
    result : loadpath.pipeline.PipelineResult
    settings : loadpath.plugin.settings.Settings
    times : dict of str -> float, s
    source : str
        Input file name.
    with_metrics : bool
        Compute the metrics (a second or so per distinct layer).
    printability : dict, optional
        The replaced blocks' counts when the run has them already (the verdict's,
        :func:`loadpath.printability.verdict_counts`); else they are counted here.

    Returns
    -------
    Report
        Call :meth:`Report.finish` (with the run's verdict) before :meth:`Report.write`.
        A layer whose figures or metrics fail is reported by a warning and a note on the page,
        never by an exception: the report never fails a run.
    """
    rep = Report()
    farea = math.pi * settings.filament_diameter**2 / 4
    layers: list[LayerReport] = []
    for k, jr in enumerate(result.jobs):
        unit = jr.units[0]
        nums = ", ".join(str(u.layer + 1) for u in jr.units)
        title = f"{unit.object}, {unit.kind} infill, layers {nums} (z = {unit.z:g} mm)"
        try:
            lr = layer_report(
                jr, result.program, result.output, result.splice, jr.job.input.field, title, farea, with_metrics
            )
        except Exception as exc:  # a figure that cannot be drawn must not cost the user the G-code
            why = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
            rep.warnings.append(f"report: layers {nums} have no figures or metrics ({why})")
            lr = LayerReport(title, [u.layer + 1 for u in jr.units], {"error": why})
        else:
            rep.files[f"layer-{k + 1}.svg"] = lr.figure
            rep.files[f"layer-{k + 1}-detail.svg"] = lr.detail
        layers.append(lr)
    data = {
        "loadpath": __version__,
        "source": source,
        "dialect": result.program.dialect.name,
        "changed": result.changed,
        "passthrough": result.passthrough,
        "verdict": None,
        "warnings": list(result.warnings) + rep.warnings,
        "times_s": {k: float(v) for k, v in times.items()},
        "settings": settings.as_dict() if settings is not None else {},
        "settings_sources": dict(settings.sources) if settings is not None else {},
        "print_time_change_s": result.splice.seconds_delta if result.splice else 0.0,
        "check": {
            "problems": result.check.problems if result.check else [],
            "volume_ratio": {
                str(k): v for k, v in (result.check.volume_ratio if result.check else {}).items()
            },
        },
        "printability": printability or _printability(result),
        "layers": [lr.numbers for lr in layers],
        "blocks": [dict(vars(b)) for b in (result.splice.blocks if result.splice else ())],
    }
    rep.data, rep.layers, rep.settings = data, layers, settings
    rep.analyses = dict(result.analyses or {})
    return rep


def _printability(result) -> dict | None:
    """Paths, retractions, travel and print time of the replaced blocks, slicer and loadpath (issue 19)."""
    if not result.changed or result.output is None:
        return None
    from loadpath.printability import replaced_blocks

    return replaced_blocks(result.program, result.output, result.splice)


def _printability_html(p: dict | None) -> str:
    if not p:
        return ""
    labels = (
        ("paths", "paths", "{:d}"),
        ("retractions", "retractions", "{:d}"),
        ("travel_mm", "travel, mm", "{:.0f}"),
        ("print_s", "print time (acceleration, jerk), s", "{:.0f}"),
        ("filament_mm", "filament, mm", "{:.1f}"),
    )
    rows = "".join(
        f"<tr><td>{html.escape(lab)}</td><td>{f.format(p['slicer'][k])}</td>"
        f"<td>{f.format(p['loadpath'][k])}</td></tr>"
        for k, lab, f in labels
    )
    return (
        "<h2>Printability of the replaced blocks (and the moves into them)</h2>"
        f"<table><tr><th></th><th>slicer</th><th>loadpath</th></tr>{rows}</table>"
    )


def _json(o: Any) -> Any:
    if hasattr(o, "item"):
        return o.item()
    if isinstance(o, (set, tuple)):
        return list(o)
    return str(o)


def _per_part(verdict: Any) -> str:
    """The verdict's figures as a table of the whole part."""
    e = html.escape
    if verdict is None or not verdict.changed:
        return ""

    def pct(v):
        return percent(v, "–")

    rows = [
        ("layers replaced", f"{len(verdict.layers)} ({', '.join(verdict.kinds)})"),
        ("predicted stiffness, absolute", pct(verdict.stiffness)),
        ("predicted stiffness, same mass", pct(verdict.stiffness_same_mass)),
        (
            f"predicted failure load, absolute ({verdict.model})",
            pct(verdict.failure_load) if verdict.failure_load is not None else "not modelled",
        ),
        (
            f"predicted failure load, same mass ({verdict.model})",
            pct(verdict.failure_load_same_mass) if verdict.failure_load is not None else "not modelled",
        ),
        (
            "print time (kinematic estimate)",
            f"{signed(verdict.time_change_s / 60)} min"
            + (f" ({signed(verdict.time_change_pct)} %)" if verdict.time_change_pct is not None else ""),
        ),
        ("mass", f"{signed(verdict.mass_change_g, 2)} g"),
    ]
    body = "".join(f"<tr><td>{e(a)}</td><td>{e(b)}</td></tr>" for a, b in rows)
    return f"<h2>Per part: what changed</h2><table><tr><th>whole part</th><th>change</th></tr>{body}</table>"


def _html(
    data: dict, layers: list[LayerReport], settings, verdict: Any = None, views: list[str] | None = None
) -> str:
    e = html.escape
    rows = "".join(f"<tr><td>{e(k)}</td><td>{v:.3f}</td></tr>" for k, v in data["times_s"].items())
    sett = ""
    if settings is not None:
        sett = "".join(
            f"<tr><td>{e(k)}</td><td>{e(str(v))}</td><td>{e(settings.source(k))}</td></tr>"
            for k, v in data["settings"].items()
        )
    warn = "".join(f"<li>{e(w)}</li>" for w in data["warnings"]) or "<li>none</li>"
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'><title>loadpath report</title>",
        "<style>body{font-family:sans-serif;max-width:1000px;margin:auto;padding:1em}"
        "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #ccc;padding:2px 8px;"
        "text-align:right}td:first-child,th:first-child{text-align:left}"
        "details{margin:0.5em 0}section{margin-top:2em;border-top:2px solid #ddd}</style></head><body>",
        f"<h1>loadpath report: {e(data['source'])}</h1>",
        (f"<p class='verdict'><b>{e(verdict.line())}</b></p>" if verdict is not None else ""),
        f"<p>{e(data['dialect'])}; engine <b>{e(str(data['settings'].get('engine')))}</b>; "
        f"{len(layers)} distinct layer(s); print time change (kinematic estimate) "
        f"{data['print_time_change_s']:+.0f} s; "
        f"{'infill replaced' if data['changed'] else 'file unchanged'}.</p>",
        _per_part(verdict),
        *(
            ["<h2>The load case on the part, and where it gained</h2>", *views]
            if views
            else []
        ),
        f"<h2>Warnings</h2><ul>{warn}</ul>",
        f"<h2>Time per stage (s)</h2><table>{rows}</table>",
        _printability_html(data.get("printability")),
        "<details><summary>Settings and where they came from</summary>"
        f"<table><tr><th>setting</th><th>value</th>"
        f"<th>from</th></tr>{sett}</table></details>",
        f"<p>Colours: {colorbar('alignment |s . p| (paths); |s| / scale (field)')}</p>",
    ]
    for lr in layers:
        n = lr.numbers
        if "error" in n:
            parts.append(
                f"<section><h2>{e(lr.title)}</h2><p>No figures or metrics for these layers: "
                f"{e(n['error'])}</p></section>"
            )
            continue
        old, new = n.get("old", {}), n.get("new", {})
        mrows = "".join(
            f"<tr><td>{e(label)}</td><td>{_num(old.get(key), f)}</td><td>{_num(new.get(key), f)}</td></tr>"
            for key, label, f in _METRIC_ROWS
        )
        extra = [
            ("extruded volume, mm³", n.get("volume_old_mm3"), n.get("volume_new_mm3"), "{:.1f}"),
            ("print time of the blocks (kinematic), s", n.get("print_s_old"), n.get("print_s_new"), "{:.1f}"),
            (
                "mean |s . p| of the printed segments",
                n.get("alignment_mean_old"),
                n.get("alignment_mean_new"),
                "{:.4f}",
            ),
        ]
        mrows += "".join(
            f"<tr><td>{e(lab)}</td><td>{_num(a, f)}</td><td>{_num(b, f)}</td></tr>" for lab, a, b, f in extra
        )
        parts += [
            f"<section><h2>{e(lr.title)}</h2>",
            f"<p>pitch {n['pitch_mm']:.3f} mm, slicer's flow width {n['flow_width_mm']:.3f} mm, principal "
            f"{e(n['principal'])}; engine {e(n.get('engine') or '')} {n['engine_s']:.2f} s for "
            f"{n['n_paths_engine']} paths; "
            "staggered by half "
            f"a pitch on layers {e(', '.join(map(str, n['staggered_layers'])) or 'none')}.</p>",
            lr.figure,
            "<p>Close-up around the largest hole, else the most stressed point "
            "(colour = alignment |s . p|):</p>",
            lr.detail,
            "<p>Metrics per layer: these layers' replaced region only (the whole part is in the "
            "table on top).</p>",
            f"<table><tr><th>metric (per layer)</th><th>slicer</th><th>loadpath</th></tr>{mrows}</table>",
            lr.hist,
            "</section>",
        ]
    parts.append("</body></html>")
    return "\n".join(parts)
