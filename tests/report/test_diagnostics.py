"""A kart lap through the CLI as a user runs it: `baseline update` stores a small reference trace
beside the numbers (and moves no number), and the next run's report has the lap table with its
sectors, the per-distance lap overlays, the commands, the track-limit margin and the baseline's
trace overlaid; a damaged trace is one clear error."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import KartLap, kartci

from kartci.project import current as active_project
from kartci.verdict.trace import load_trace


def _figures(report: Path, scenario: str) -> list[dict[str, Any]]:
    text = report.read_text(encoding="utf-8")
    block = re.search(rf'data-scenario="{scenario}"><script type="application/json">(.*?)'
                      r"</script>", text, re.S)
    assert block is not None
    figures: list[dict[str, Any]] = json.loads(block.group(1).replace("<\\/", "</"))["figures"]
    return figures


def test_baseline_update_stores_a_small_trace_and_moves_no_number(kart_lap: KartLap) -> None:
    trace = kart_lap.baselines / "traces" / "kart_manual.json"
    assert f"reference trace {trace} ({trace.stat().st_size} bytes)" in kart_lap.update.stdout
    assert 1_000 < trace.stat().st_size < 20_000
    metrics = json.loads((kart_lap.out / "kart_manual" / "metrics.json").read_text())
    stored = json.loads((kart_lap.baselines / "kart_manual.json").read_text())["metrics"]
    assert {k: v["value"] for k, v in stored.items()} == {
        k: v["value"] for k, v in metrics["metrics"].items()}
    ref = load_trace(trace)["kart0"]
    assert list(ref.columns) == ["offset", "s_total", "speed", "t", "x", "y"]
    assert ref["t"].diff().dropna().between(0.19, 0.21).all()  # one row per 0.2 s
    assert len(ref) == 86  # 0 .. 17 s


def test_report_overlays_the_trace_and_draws_the_diagnostics(kart_lap: KartLap) -> None:
    figures = {f["key"]: f for f in _figures(kart_lap.out / "report.html", "kart_manual")}
    assert list(figures) == ["plane", "lap_speed", "lap_offset", "speed", "controls", "margin",
                             "wheels"]
    labels = {k: [s["label"] for s in f["series"]] for k, f in figures.items()}
    assert "baseline kart0" in labels["plane"] and "baseline kart0" in labels["speed"]
    assert labels["lap_speed"] == ["baseline kart0 lap 1", "baseline kart0 lap 2",
                                   "kart0 lap 1", "kart0 lap 2"]
    assert labels["controls"] == ["kart0 steering_wheel_angle_rad", "kart0 acceleration_mps2",
                                  "kart0 brake_mps2"]
    # the run is the baseline's: its trace lies on the run's path
    ref_s, run_s = figures["speed"]["series"]
    on_run = np.interp(ref_s["x"], run_s["x"], run_s["y"])
    assert np.abs(on_run - np.asarray(ref_s["y"])).max() < 0.01
    # colour scale fitted to the data: speeds coloured on the plane are those of the run
    path = next(s for s in figures["plane"]["series"] if s["c"])
    assert min(path["c"]) == 0.0 and 4.5 < max(path["c"]) < 5.0


def test_lap_table_sectors_add_up_and_best_is_marked(kart_lap: KartLap) -> None:
    text = (kart_lap.out / "report.html").read_text(encoding="utf-8")
    table = re.search(r'<table class="laps">.*?</table>', text, re.S)
    assert table is not None
    rows = re.findall(r"<tr><td>(\d+)</td>(.*?)</tr>", table.group(0))
    assert [r[0] for r in rows] == ["1"]  # one complete lap in 17 s
    cells = [float(c) for c in re.findall(r">([\d.]+) s</td>", rows[0][1])]
    lap, sectors = cells[0], cells[1:]
    metrics = json.loads((kart_lap.out / "kart_manual" / "metrics.json").read_text())
    assert lap == pytest.approx(metrics["metrics"]["best_lap_s"]["value"], abs=0.0005)
    assert len(sectors) == 3 and sum(sectors) == pytest.approx(lap, abs=0.0015)
    assert rows[0][1].count('class="best"') == 4  # a single lap is the best of everything
    static = (kart_lap.out / "report-static.html").read_text(encoding="utf-8")
    figures = static.count("<svg") - static.count('<svg class="icon"')  # not the status icons
    assert "<script" not in static and figures == 7  # the fallback draws every figure


def test_a_damaged_trace_is_one_clear_error(kart_lap: KartLap, tmp_path: Path) -> None:
    (tmp_path / "traces").mkdir()
    for f in (kart_lap.baselines).glob("*.json"):
        (tmp_path / f.name).write_text(f.read_text())
    (tmp_path / "traces" / "kart_manual.json").write_text('{"version": 1, "agents": [')
    res = kartci("report", kart_lap.out, "--baselines", tmp_path, "--no-strict")
    assert res.returncode == 2
    assert "malformed reference trace" in res.stdout + res.stderr
    assert "Traceback" not in res.stdout + res.stderr
    assert (kart_lap.out / "kart_manual" / "run.mcap").is_file()  # nothing destroyed


def test_every_shipped_scenario_has_a_small_reference_trace() -> None:
    from kartci import project
    from kartci.runner.jobs import default_suite

    proj = project.current()
    for name in default_suite(proj.own_scenarios(), active_project()):
        path = proj.baselines / "traces" / f"{name}.json"
        assert path.is_file(), f"no reference trace for {name}: run `kartci baseline update`"
        assert path.stat().st_size < 20_000
        agents = load_trace(path)
        assert agents and all(len(f) > 20 and f["t"].is_monotonic_increasing
                              for f in agents.values())
