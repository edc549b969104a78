"""The reports in a real browser: headless Chromium loads report.html (a line lab and a kart lap
with its baseline's reference trace) and a comparison report with no console errors; every figure
is drawn; a real mouse hover moves the shared time cursor (the legend reads values, the view from
above shows the moment) and a real wheel event zooms every time plot of the scenario together.
Screenshots go to $KARTCI_ARTIFACTS (default reports/browser/ in the checkout), which CI keeps."""

from __future__ import annotations

import base64
import io
import json
import os
import shutil
from pathlib import Path

import pytest
from cdp import Browser, find_browser
from helpers import EMOJI, PAIR, ROOT, KartLap, glance_results
from PIL import Image

from kartci.project import current as active_project
from kartci.report import COMPARE, write_all
from kartci.report.history import write_history
from kartci.runner import expand, run_jobs
from kartci.runner.compare import compare_outs

QUICK = ["duration_s=3", "criteria={}", "metrics.line_tracking.transient_s=1"]
ARTIFACTS = Path(os.environ.get("KARTCI_ARTIFACTS", ROOT / "reports" / "browser"))

FIGURES = """JSON.stringify({
  charts: kartciFigures.charts.map(c => [c.scenario, c.key, c.chart.over.clientWidth,
                                         c.chart.over.clientHeight, c.chart.data.length]),
  planes: kartciFigures.planes.map(p => [p.scenario, p.plane.canvas.clientWidth]),
})"""


@pytest.fixture(scope="module")
def reports(tmp_path_factory: pytest.TempPathFactory, kart_lap: KartLap) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("browser")
    baselines = root / "baselines"
    baselines.mkdir()
    base = run_jobs(expand(PAIR, QUICK,
                           active_project()), root / "base", baselines, active_project())
    head = run_jobs(expand(PAIR, [*QUICK, "agents.lt0.controller.kp=20"],
                           active_project()), root / "head",
                    baselines, active_project())
    assert not [r.error for r in base + head if r.error]
    kart = kart_lap.result  # a lap judged against its baseline, with the reference trace
    write_all([*head, kart], root / "head")  # a line lab and a race track
    shutil.copytree(kart_lap.out / "kart_manual", root / "head" / "kart_manual")
    cmp = compare_outs(root / "base", root / "head", baselines, active_project())
    write_all(cmp, root / "cmp", COMPARE)
    return root / "head" / "report.html", root / "cmp" / "report.html"


def _center(browser: Browser, session: str, selector: str) -> tuple[float, float]:
    rect = json.loads(browser.evaluate(session, f"""(() => {{
      const e = {selector}; e.scrollIntoView({{block: 'center'}});
      const r = e.getBoundingClientRect();
      return JSON.stringify([r.left + r.width / 2, r.top + r.height / 2]); }})()"""))
    return float(rect[0]), float(rect[1])


def _shot(browser: Browser, session: str, name: str) -> None:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    data = browser.send("Page.captureScreenshot", session, format="png")["data"]
    (ARTIFACTS / name).write_bytes(base64.b64decode(data))


@pytest.mark.long(reason="two runs and headless Chromium")
@pytest.mark.parametrize("which", [0, 1], ids=["run report", "comparison report"])
def test_report_is_interactive_in_headless_chromium(reports: tuple[Path, Path], which: int,
                                                    tmp_path: Path) -> None:
    exe = find_browser()
    if exe is None:
        pytest.skip("no headless Chromium: install Debian's chromium package (.ci/run does)")
    page = reports[which]
    browser = Browser(exe, tmp_path / "profile")
    try:
        session = browser.open(page.as_uri())
        browser.send("Emulation.setDeviceMetricsOverride", session, width=1250, height=1400,
                     deviceScaleFactor=1, mobile=False)
        figs = json.loads(browser.evaluate(session, FIGURES))
        title = browser.evaluate(session, "document.title")
        chart = "kartciFigures.charts.find(c => c.scenario === 'line_circle' && " \
                "c.key === 'tracking')"
        # hover: a real mouse move over the tracking-error plot
        x, y = _center(browser, session, f"{chart}.chart.over")
        before = browser.evaluate(session, f"{chart}.chart.cursor.idx")
        browser.send("Input.dispatchMouseEvent", session, type="mouseMoved", x=x, y=y)
        hovered = json.loads(browser.evaluate(session, f"""JSON.stringify([
          {chart}.chart.cursor.idx,
          [...{chart}.chart.root.querySelectorAll('.u-value')].map(e => e.textContent),
          kartciFigures.planes.find(p => p.scenario === 'line_circle').plane.t])"""))
        _shot(browser, session, f"{'compare' if which else 'run'}-hover.png")
        # zoom: a real wheel event; every time plot of the scenario follows
        scales = """JSON.stringify(kartciFigures.charts.filter(c => c.scenario ===
          'line_circle' && c.chart.data[0].length && c.key !== 'lap_speed' &&
          c.key !== 'lap_offset').map(c => [c.chart.scales.x.min, c.chart.scales.x.max]))"""
        zoom_before = json.loads(browser.evaluate(session, scales))
        browser.send("Input.dispatchMouseEvent", session, type="mouseWheel", x=x, y=y,
                     deltaX=0, deltaY=-120)
        zoom_after = json.loads(browser.evaluate(session, scales))
        if not which:
            x, y = _center(browser, session,
                           "document.querySelector('#kart_manual .kfigs')")
            _shot(browser, session, "run-kart.png")
        errors = browser.console_errors()
    finally:
        browser.close()
    assert errors == []
    assert title == ("kartci compare report" if which else "kartci report")
    scenarios = {c[0] for c in figs["charts"]}
    assert scenarios == {"line_circle", "line_straight", "kart_manual"}  # head-only in compare
    assert all(w > 300 and h > 100 and n >= 2 for _, _, w, h, n in figs["charts"]), figs
    assert [p[1] for p in figs["planes"]] == [560] * len(scenarios)
    assert before is None and hovered[0] is not None  # the hover moved the cursor
    assert any(v not in ("", "--") for v in hovered[1][1:])  # the legend reads values
    assert hovered[2] is not None  # the view from above follows the time cursor
    assert len(zoom_after) >= 2
    lo0, hi0 = zoom_before[0]
    lo1, hi1 = zoom_after[0]
    assert hi1 - lo1 == pytest.approx((hi0 - lo0) * 0.8)  # zoomed in by the wheel step
    assert all(z == zoom_after[0] for z in zoom_after)  # shared by the scenario's time plots


def test_history_page_names_the_commit_under_the_cursor(tmp_path: Path) -> None:
    exe = find_browser()
    if exe is None:
        pytest.skip("no headless Chromium: install Debian's chromium package (.ci/run does)")
    files = []
    for i, lap in enumerate([12.5, 12.25, 13.0]):
        doc = {"exit_code": 0, "scenarios": {"kart_lap": {"metrics": {"lap_s": {"value": lap}}}}}
        files.append(tmp_path / f"00000{i}-c{i}.json")
        files[-1].write_text(json.dumps(doc))
    page = write_history(files, tmp_path)
    browser = Browser(exe, tmp_path / "profile")
    try:
        session = browser.open(page.as_uri())
        chart = "kartciFigures.charts[0].chart"
        x, y = _center(browser, session, f"{chart}.over")
        browser.send("Input.dispatchMouseEvent", session, type="mouseMoved", x=x, y=y)
        legend = json.loads(browser.evaluate(session, f"""JSON.stringify(
          [...{chart}.root.querySelectorAll('.u-value')].map(e => e.textContent))"""))
        errors = browser.console_errors()
    finally:
        browser.close()
    assert errors == []
    assert legend == ["000001-c1", "12.25"]  # the middle commit, by name, and its value


GLANCE = """JSON.stringify({
  verdict: document.querySelector('p.verdict').textContent,
  index: [...document.querySelectorAll('table')[0].querySelectorAll('tr')].slice(1)
    .map(r => r.textContent.trim()),
  sections: [...document.querySelectorAll('section')].map(s => s.id),
  icons: [...document.querySelectorAll('svg.icon')].map(s => {
    const r = s.getBoundingClientRect(); return [r.width, r.height]; }),
  first: (() => { const r = document.querySelector('table svg.icon').getBoundingClientRect();
                  return [r.left, r.top, r.width, r.height]; })(),
})"""


def test_report_reads_at_a_glance_without_an_emoji_font(tmp_path: Path) -> None:
    """Status marks are inline SVG shapes with words (no emoji font needed: a stock headless
    Chromium has none), the failures come first in the index and the sections, under a
    one-line verdict; the screenshot (report-glance.png) shows it."""
    exe = find_browser()
    if exe is None:
        pytest.skip("no headless Chromium: install Debian's chromium package (.ci/run does)")
    paths = write_all(glance_results(), tmp_path / "out")
    for name in ("html", "static", "markdown"):
        assert not EMOJI.search(paths[name].read_text(encoding="utf-8")), name
    browser = Browser(exe, tmp_path / "profile")
    try:
        session = browser.open(paths["html"].as_uri())
        browser.send("Emulation.setDeviceMetricsOverride", session, width=900, height=700,
                     deviceScaleFactor=1, mobile=False)
        page = json.loads(browser.evaluate(session, GLANCE))
        png = base64.b64decode(browser.send("Page.captureScreenshot", session,
                                            format="png")["data"])
        errors = browser.console_errors()
    finally:
        browser.close()
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    (ARTIFACTS / "report-glance.png").write_bytes(png)
    assert errors == []
    assert page["verdict"] == ("FAIL: 2 of 13 scenarios fail: scenario_09 (error), scenario_06 "
                               "(regressed) (1 error, 1 regressed, 11 pass)")
    assert page["index"][:3] == ["scenario_09 ERROR", "scenario_06 REGRESSED",
                                 "scenario_00 pass"]
    assert page["sections"][:3] == ["scenario_09", "scenario_06", "scenario_00"]
    assert len(page["icons"]) == 13 * 2 + 12 and all(i == [14, 14] for i in page["icons"])
    left, top, _, height = page["first"]  # the error's octagon: red where it is drawn
    image = Image.open(io.BytesIO(png)).convert("RGB")
    pixel = image.getpixel((round(left + 2), round(top + height / 2)))
    assert isinstance(pixel, tuple)
    r, g, b = pixel[:3]
    assert r > 150 and g < 60 and b < 60, (r, g, b)
