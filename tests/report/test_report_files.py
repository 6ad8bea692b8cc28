"""The report's folder holds this run's report only."""

from __future__ import annotations

from loadpath.report import Report


def test_a_report_written_over_an_earlier_one_leaves_none_of_its_figures(tmp_path):
    first = Report()
    first.files.update({f"layer-{k}.svg": "<svg/>" for k in (1, 2, 3, 4)} | {"index.html": "a"})
    first.files["layer-4-detail.svg"] = "<svg/>"
    first.write(tmp_path)
    (tmp_path / "notes.txt").write_text("the user's", encoding="utf-8")
    second = Report()
    second.files.update({"layer-1.svg": "<svg/>", "index.html": "b", "part-1.svg": "<svg/>"})
    second.write(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["index.html", "layer-1.svg", "notes.txt", "part-1.svg"]
