"""The team's plugins keep kartci's contracts: `kartci.testing.check_kind` builds, resets, steps
and scores the scenario that uses them, twice, and names any part that breaks its contract."""

from __future__ import annotations

from kartci.testing import check_kind


def test_the_driver_and_the_metric_set_pass_check_kind() -> None:
    checked = check_kind("pure_pursuit_lap", controller="pure_pursuit", metrics=("cornering",),
                         duration_s=3.0)
    assert "controller 'pure_pursuit': contract" in checked.lines
    assert "metric set 'cornering': contract" in checked.lines
