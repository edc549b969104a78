"""The study figures: curves read back from a grid's run folders, drawn as SVG."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import kartci

from kartci.robots.line_tracker import figures, study


@pytest.mark.long(reason="several robot runs")
def test_study_draws_the_step_time_panel_from_a_two_point_grid(tmp_path: Path) -> None:
    out = tmp_path / "out"
    r = kartci("run", "line_straight_grid", "--out", out, "--set", "duration_s=2",
               "--set", "metrics.line_tracking.transient_s=1",
               "--set", "metrics.line_response.transient_s=1",
               "--sweep", "agents.lt0.controller.period_s=0.04,0.1")
    assert r.returncode in (0, 1), r.stderr  # no baselines for these short points
    curves = study.grid(out, "line_straight_grid")
    assert [c.point[study.TS] for c in curves] == [0.04, 0.1]
    assert abs(curves[0].offset_m[0] - 0.005) < 1e-3 and curves[0].t_s[-1] > 1.9
    panels = [p for p in study.straight_panels(curves) if p.curves]
    assert [p.figure for p in panels] == ["Fig. 7.1.2"]
    svg = figures.responses(panels[0])
    assert svg.startswith("<svg") and "ts 0.04 s" in svg and "ts 0.1 s" in svg
    r = kartci("study", out)
    assert r.returncode == 0, r.stderr
    assert (out / "study.html").read_text().count("<svg") == 1


def test_study_of_a_folder_without_grids_is_one_clear_line(tmp_path: Path) -> None:
    r = kartci("study", tmp_path)
    assert r.returncode == 2
    assert "no line-tracker grid runs" in r.stderr and "Traceback" not in r.stderr
