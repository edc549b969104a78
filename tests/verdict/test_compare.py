"""`kartci compare`: base vs head, asv's significance rule, and what CI shows of it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import PAIR, QUICK, ROOT, kartci
from junitparser import JUnitXml

from kartci.core import Direction
from kartci.project import current as active_project
from kartci.report.ci import annotation_lines, scenario_files, truncate
from kartci.report.markdown import summary_md
from kartci.verdict import MetricVerdict, Status
from kartci.verdict.result import ScenarioResult
from kartci.verdict.runs import compare_runs, significant


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A base run and a head run with a lower controller gain, two seeds each."""
    root = tmp_path_factory.mktemp("compare")
    (root / "baselines").mkdir()
    for name, extra in (("base", []), ("head", ["--set", "agents.lt0.controller.kp=20"])):
        p = kartci("run", *PAIR, *QUICK, *extra, "--repeat", "2", "-j", "2",
                   "--out", root / name, "--baselines", root / "baselines")
        assert p.returncode == 0, p.stderr
    return root


@pytest.mark.long(reason="several kartci runs end to end")
def test_repeats_are_stored_beside_the_judged_run(runs: Path) -> None:
    seeds = [json.loads((runs / "base" / "line_circle" / sub / "metrics.json").read_text())
             ["seed"] for sub in (".", "repeat_1")]
    assert seeds == [1, 2]
    assert not (runs / "base" / "line_circle" / "repeat_2").exists()


@pytest.mark.long(reason="kartci runs end to end")
def test_compare_identical_runs_exits_0(runs: Path) -> None:
    p = kartci("compare", runs / "base", runs / "base", "--out", runs / "same",
               "--baselines", runs / "baselines")
    assert p.returncode == 0, p.stdout + p.stderr
    summary = json.loads((runs / "same" / "summary.json").read_text())
    statuses = {m["status"] for s in summary["scenarios"].values()
                for m in s["metrics"].values()}
    assert statuses == {"pass"}


@pytest.mark.long(reason="kartci runs end to end")
def test_a_worse_head_exits_1_and_every_output_names_the_regression(runs: Path) -> None:
    step_summary = runs / "step_summary.md"
    step_summary.write_text("earlier step\n")
    out = runs / "cmp"
    p = kartci("compare", runs / "base", runs / "head", "--out", out, "--baselines",
               runs / "baselines", env={"GITHUB_ACTIONS": "true",
                                        "GITHUB_STEP_SUMMARY": str(step_summary)})
    assert p.returncode == 1, p.stdout + p.stderr
    metric = "cross_track_rms_m"
    html = (out / "report.html").read_text()
    assert "kartci compare report" in html and f"<td>{metric}</td>" in html
    assert 'class="regressed"' in html and html.count('class="kfigs"') == 2
    static = (out / "report-static.html").read_text()
    figures = static.count("<svg") - static.count('<svg class="icon"')  # not the status icons
    assert figures == 6  # 3 overlaid plots each
    md = (out / "summary.md").read_text()
    assert f"`{metric}`" in md and "| base |" in md and "regressed" in md
    assert step_summary.read_text() == "earlier step\n" + md  # appended, not replaced
    cases = [c for suite in JUnitXml.fromfile(str(out / "junit.xml")) for c in suite]
    assert sorted(c.name for c in cases) == sorted(PAIR)
    summary = json.loads((out / "summary.json").read_text())["scenarios"]
    for c in cases:  # one failure per regressed metric, each named
        regressed = sorted(n for n, m in summary[c.name]["metrics"].items()
                           if m["status"] == "regressed")
        assert sorted((f.message or "").split()[0] for f in c.result) == regressed
    assert all(any(metric in (f.text or "") for f in c.result) for c in cases)
    assert f"report: {out / 'report.html'}" in (cases[0].system_out or "")
    notes = [line for line in p.stdout.splitlines() if line.startswith("::error file=scenarios/")]
    assert 0 < len(notes) <= 10 and any(metric in n for n in notes)


def _v(name: str, value: float, base: float, tol: float) -> MetricVerdict:
    return MetricVerdict(name, value, "m", base, tol, Direction.LOWER, Status.REGRESSED)


def test_annotations_stop_at_ten_and_say_how_many_more() -> None:
    r = ScenarioResult("s", "", [_v(f"m{i}", 1.0 + i, 0.0, 1.0) for i in range(12)])
    lines = annotation_lines([r])
    assert len(lines) == 11 and lines[-1].startswith("kartci: 2 more")
    assert "m11" in lines[0]  # the largest regression first
    assert "title=kartci s%3A m11 regressed" in lines[0]  # ':' escaped in a property


def test_annotations_are_anchored_to_the_scenario_file() -> None:
    r = ScenarioResult("line_circle@kp=20", "", [_v("m", 2.0, 0.0, 1.0)])
    files = scenario_files([r], active_project(), ROOT)
    assert files == {"line_circle@kp=20": "scenarios/line_circle.yaml"}
    [line] = annotation_lines([r], files=files)
    assert line.startswith("::error file=scenarios/line_circle.yaml,line=1,title=")
    # not in that repository: no anchor
    assert scenario_files([r], active_project(), ROOT / "tests") == {}
    assert scenario_files([ScenarioResult("no_such", "")], active_project(), ROOT) == {}


def test_summary_puts_the_largest_regression_first_and_truncates_with_a_note() -> None:
    small = ScenarioResult("a_small", "", [_v("x", 1.1, 1.0, 0.05)])
    big = ScenarioResult("b_big", "", [_v("y", 9.0, 1.0, 0.05)])
    md = summary_md([small, big])
    assert md.index("### `b_big`") < md.index("### `a_small`")
    many = [ScenarioResult(f"s{i:04d}", "", [_v("x", 2.0, 1.0, 0.1)]) for i in range(3000)]
    text = truncate(summary_md(many), 20_000)
    assert len(text.encode()) <= 20_000 and "Truncated:" in text.splitlines()[-1]


def test_significance_follows_asv() -> None:
    assert not significant([1.0, 2.0, 3.0], [2.5, 3.5, 4.5])  # ranges overlap (n = 3)
    assert significant([1.0, 2.0, 3.0], [3.5, 4.0, 5.0])  # ranges apart
    lo, hi = [1.0, 1.1, 1.2, 1.3, 1.4], [2.0, 2.1, 2.2, 2.3, 2.4]
    assert significant(lo, hi)  # Mann-Whitney U, p = 0.008
    assert not significant(lo, [1.05, 1.15, 1.25, 1.35, 1.45])
    assert significant([1.0], [1.0])  # no spread known: the tolerance alone decides


def test_a_change_beyond_tolerance_counts_only_when_significant() -> None:
    def samples(*values: float) -> dict[str, dict[str, object]]:
        return {"cross_track_rms_m": {"unit": "m", "values": list(values)}}

    stored = {"cross_track_rms_m": {"value": 1.0, "tolerance": 0.1, "direction": "lower"}}
    noisy = compare_runs(samples(1.0, 1.5, 2.0), samples(1.3, 1.8, 2.3), stored)
    assert noisy[0].status is Status.PASS and noisy[0].delta == pytest.approx(0.3)
    clear = compare_runs(samples(1.0, 1.1, 1.2), samples(1.5, 1.6, 1.7), stored)
    assert clear[0].status is Status.REGRESSED and clear[0].tolerance == 0.1
    better = compare_runs(samples(1.0), samples(0.5), None)
    assert better[0].status is Status.IMPROVED  # default tolerance from the metric's DEFS
    gone = compare_runs(samples(1.0), {}, None)
    assert gone[0].status is Status.MISSING
