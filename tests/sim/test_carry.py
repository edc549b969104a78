"""A kidnap as a scenario event: `agents.<name>.carry` moves the robot itself once."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kartci.logs import tables
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import simulate


def test_carry_moves_the_kart_once_and_keeps_its_speed(tmp_path: Path) -> None:
    log = tmp_path / "run.mcap"
    simulate(load_scenario("kart_manual", ["duration_s=2", "criteria={}",
                                           "agents.kart0.carry={at_s: 1.0, offset_m: [0.0, 1.0]}"],
                                           project=active_project()),
             log)
    odom = tables(log, ["/kart0/odom"])["/kart0/odom"]
    t, x, y, vx = (odom[c].to_numpy() for c in ("t", "x", "y", "vx"))
    i = int(np.searchsorted(t, 1.0))  # the first pose at or after the carry
    steps = np.hypot(np.diff(x), np.diff(y))
    assert steps[i - 1] == pytest.approx(1.0, abs=0.1)  # the jump: 1 m (plus one step's travel)
    assert np.delete(steps, i - 1).max() < 0.2  # nowhere else
    assert y[i] - y[i - 1] == pytest.approx(1.0, abs=0.1)
    assert vx[i + 1] == pytest.approx(vx[i - 1], rel=0.2, abs=0.1)  # still moving as before
