"""A misspelt name gets the nearest known one (the CLI's `did_you_mean`, one function for all):
metric names in criteria, agent names, controller, world and robot kinds, worlds and models,
override keys at any depth. Validation only: nothing runs."""

from __future__ import annotations

import pytest

from kartci.core import WORLDS
from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.runner.run import check_criteria_names
from kartci.scenario import load_scenario

CASES = {
    "criteria.cross_trak_max_m={max: 1}":
        "criteria on unknown metrics: cross_trak_max_m (did you mean 'cross_track_max_m'?)",
    "criteria={lt1.completion: {min: 1}}":
        "criteria on unknown metrics: lt1.completion (did you mean 'lt0.completion'?)",
    "agents.lt0.controller.type=line_pdi": "unknown controller 'line_pdi' (did you mean "
                                           "'line_pid'?)",
    "agents.lt0.model=line_traker": "robot model 'line_traker' not found (did you mean "
                                    "'line_tracker'?)",
    "world=line_lab/straigt": "world 'line_lab/straigt' not found (did you mean "
                              "'line_lab/straight'?)",
    "metrics.line_trackin={}": "unknown metric set 'line_trackin' (did you mean "
                               "'line_tracking'?)",
    "agents.lt1.start.along_m=1": "--set agents.lt1.start.along_m: unknown agent 'lt1' (did you "
                                  "mean 'lt0'?)",
    "agents.lt0.contoller.kp=1": "agents.lt0.contoller: unknown key (did you mean "
                                 "'controller'?)",
    "agents.lt0.controller.kpp=1": "agents.lt0.controller.kpp (from --set): unknown key (did you "
                                   "mean 'kp'?)",
    "agents.lt0.start.alng_m=1": "agents.lt0.start.alng_m (from --set): unknown key (did you "
                                 "mean 'along_m'?)",
    "duration_ss=1": "duration_ss (from --set): unknown key (did you mean 'duration_s'?)",
}


@pytest.mark.parametrize("override", list(CASES))
def test_a_misspelt_name_gets_the_nearest_known_one(override: str) -> None:
    with pytest.raises(SpecError) as err:
        check_criteria_names([load_scenario("line_straight", [override],
                                            project=active_project())], active_project())
    assert CASES[override] in str(err.value)


def test_a_misspelt_world_kind_gets_the_nearest_one() -> None:
    with pytest.raises(SpecError, match=r"^unknown world kind 'line_lba' \(did you mean "
                                        r"'line_lab'\?\)$"):
        WORLDS.get("line_lba")
