"""`kartci history`: successive commits' summary.json files become one series per metric, the
commits named on the x axis, a gap where a commit lacks the metric; a file that is not a summary
is one clear error."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from helpers import kartci

from kartci.core import Direction
from kartci.report import summary_json, write_all
from kartci.verdict import MetricVerdict, Status
from kartci.verdict.result import ScenarioResult


def _summary(path: Path, values: dict[str, float]) -> Path:
    verdicts = [MetricVerdict(name, v, "m", None, None, Direction.LOWER, Status.NEW)
                for name, v in values.items()]
    path.write_text(json.dumps(summary_json([ScenarioResult("kart_lap", "", verdicts)])))
    return path


def _figures(page: Path) -> list[dict[str, Any]]:
    block = re.search(r'data-scenario="history kart_lap"><script type="application/json">'
                      r"(.*?)</script>", page.read_text(encoding="utf-8"), re.S)
    assert block is not None
    figures: list[dict[str, Any]] = json.loads(block.group(1).replace("<\\/", "</"))["figures"]
    return figures


def test_history_draws_each_metric_across_commits(tmp_path: Path) -> None:
    files = [_summary(tmp_path / "000001-aaa.json", {"lap_s": 12.5, "rms_m": 0.6}),
             _summary(tmp_path / "000002-bbb.json", {"lap_s": 12.25}),
             _summary(tmp_path / "000003-ccc.json", {"lap_s": 13.0, "rms_m": 0.5})]
    p = kartci("history", *files, "--out", tmp_path / "h")
    assert p.returncode == 0, p.stderr
    assert "3 commits" in p.stdout
    figs = {f["key"]: f for f in _figures(tmp_path / "h" / "history.html")}
    assert sorted(figs) == ["history_lap_s", "history_rms_m"]
    assert figs["history_lap_s"]["ticks"] == ["000001-aaa", "000002-bbb", "000003-ccc"]
    [lap] = figs["history_lap_s"]["series"]
    assert lap["x"] == [0.0, 1.0, 2.0] and lap["y"] == [12.5, 12.25, 13.0]
    assert figs["history_rms_m"]["series"][0]["y"] == [0.6, None, 0.5]  # a gap, not a zero


def test_a_file_that_is_not_a_summary_is_one_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"exit_code": 0}')
    p = kartci("history", bad, "--out", tmp_path)
    assert p.returncode == 2
    assert p.stderr.strip() == f"kartci: error: {bad}: not a kartci summary.json ('scenarios')"


def test_the_merged_report_plots_the_history_with_this_run_last(tmp_path: Path) -> None:
    earlier = tmp_path / "summaries"
    earlier.mkdir()
    _summary(earlier / "000001-aaa.json", {"lap_s": 12.5})
    _summary(earlier / "000002-bbb.json", {"lap_s": 12.25})
    now = [ScenarioResult("kart_lap", "", [MetricVerdict("lap_s", 11.75, "s", None, None,
                                                          Direction.LOWER, Status.NEW)])]
    write_all(now, tmp_path / "out", history=earlier)
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert "<h2>Metric history</h2><p>2 earlier commits" in page
    [fig] = _figures(tmp_path / "out" / "report.html")
    assert fig["ticks"] == ["000001-aaa", "000002-bbb", "this run"]
    assert fig["series"][0]["y"] == [12.5, 12.25, 11.75]
    write_all(now, tmp_path / "none", history=tmp_path / "missing")  # no branch yet: no plot
    assert "Metric history" not in (tmp_path / "none" / "report.html").read_text()
