"""The reports in a real browser: headless Chromium loads report.html and a comparison report
with no console errors, and every plot is laid out with something drawn in it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cdp import Browser, find_browser
from helpers import PAIR

from kartci.report import COMPARE, write_all
from kartci.runner import expand, run_jobs
from kartci.runner.compare import compare_outs

QUICK = ["duration_s=3", "criteria={}", "metrics.line_tracking.transient_s=1"]
PLOTS = """JSON.stringify([...document.querySelectorAll('svg')].map(s => {
  const r = s.getBoundingClientRect();
  return [r.width, r.height, s.querySelectorAll('path, use').length];
}))"""


@pytest.fixture(scope="module")
def reports(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("browser")
    (root / "baselines").mkdir()
    base = run_jobs(expand(PAIR, QUICK), root / "base", root / "baselines")
    head = run_jobs(expand(PAIR, [*QUICK, "agents.lt0.controller.kp=20"]), root / "head",
                    root / "baselines")
    kart = run_jobs(expand(["kart_wall"], QUICK), root / "head", root / "baselines")
    assert not [r.error for r in base + head + kart if r.error]
    write_all(head + kart, root / "head")  # a line lab and a race track
    cmp = compare_outs(root / "base", root / "head", root / "baselines")
    write_all(cmp, root / "cmp", COMPARE)
    return root / "head" / "report.html", root / "cmp" / "report.html"


@pytest.mark.parametrize("which", [0, 1], ids=["run report", "comparison report"])
def test_report_renders_in_headless_chromium(reports: tuple[Path, Path], which: int,
                                             tmp_path: Path) -> None:
    exe = find_browser()
    if exe is None:
        pytest.skip("no headless Chromium: install Debian's chromium package (.ci/run does)")
    page = reports[which]
    browser = Browser(exe, tmp_path / "profile")
    try:
        session = browser.open(page.as_uri())
        plots = json.loads(browser.evaluate(session, PLOTS))
        title = browser.evaluate(session, "document.title")
        errors = browser.console_errors()
    finally:
        browser.close()
    assert errors == []
    assert title == ("kartci compare report" if which else "kartci report")
    expected = page.read_text().count("<svg")
    assert len(plots) == expected >= 6
    assert all(w > 100 and h > 100 and n > 5 for w, h, n in plots), plots
