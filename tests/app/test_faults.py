"""Issue 42, `kartci faults`: the catalogue each kind declares names only keys its parameters
have, a fault changes the scenario as declared, not-applicable is told apart from missed, and
the command writes the detection matrix its runs' metrics imply."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml
from helpers import kartci
from pydantic import BaseModel

from kartci.app.faults import Cell, Entry, Scope, catalogue, injection, select
from kartci.core import Change, Fault, Op, unknown_keys
from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.robots.gokart import GokartModel, KartSensors
from kartci.scenario import load_scenario
from kartci.scenario.load import scenario_loader

STANDARD = catalogue()
BY_NAME = {e.name: e for e in STANDARD}
# a shipped scenario each owner's faults act on
HOST = {"gokart": "mpcc_lap", "mpcc": "mpcc_lap", "hall": "mpcc_lap", "circuit": "mpcc_circuit",
        "line_tracker": "line_straight", "line_pid": "line_circle_pi",
        "line_lab": "line_straight"}
LIDAR_HOST = "localization_lap"  # the lidar is off in mpcc_lap


def test_the_standard_catalogue_has_the_issues_faults_declared_by_their_owners() -> None:
    for name in ("gokart.motor_power_x0.5", "gokart.wheel_torque_x0.7", "gokart.mass_+50pct",
                 "gokart.steering_rate_0.6", "gokart.brake_x0.5", "gokart.tyre_friction_0.8",
                 "line_pid.kp_x0.7", "hall.floor_friction_x0.8", "line_lab.floor_friction_x0.8"):
        assert name in BY_NAME, name
    assert BY_NAME["line_pid.kp_x0.7"].scope is Scope.CONTROLLER
    assert BY_NAME["hall.floor_friction_x0.8"].scope is Scope.WORLD


def test_every_fault_key_exists_in_its_owners_parameters() -> None:
    """`catalogue` checks every key against the owner's models (it raised otherwise); the check
    itself finds a key the model lacks, at any depth."""
    roots: dict[str, type[BaseModel] | None] = {"model": GokartModel, "sensors": KartSensors}
    typo = Fault("x", "", (Change.scale("model.motor_powr_w", 0.5),
                           Change.to("sensors.imu.gyro_nois_std_radps", 1.0),
                           Change.to("sensors.imu.enabled", False),
                           Change.to("controller.kp", 1.0)), when=("sensors.lidr.enabled",))
    assert unknown_keys(typo, roots) == ["model.motor_powr_w", "sensors.imu.gyro_nois_std_radps",
                                         "controller.kp", "sensors.lidr.enabled"]
    assert all(not unknown_keys(e.fault, roots) for e in STANDARD if e.owner == "gokart")


@pytest.mark.parametrize("entry", STANDARD, ids=lambda e: e.name)
def test_a_fault_changes_the_scenario_as_declared(entry: Entry) -> None:
    """Injected into a scenario of its owner, every fault validates (the `--set` machinery)
    and leaves each key at the declared value, everything else as it was."""
    name = LIDAR_HOST if entry.fault.read_by else HOST[entry.owner]  # a sensor: its reader
    load = scenario_loader(name, project=active_project())
    nominal = load([])
    acts = injection(nominal, entry)
    assert acts.overrides, acts.why_not
    faulted = load(list(acts.overrides))
    before, after = nominal.model_dump(mode="json"), faulted.model_dump(mode="json")
    prefix = next(iter(acts.overrides)).split("=")[0][:-len(entry.fault.changes[0].key)]
    for c in entry.fault.changes:
        old, new = _at(before, prefix + c.key), _at(after, prefix + c.key)
        if c.op is Op.SET:
            want = c.value
        else:  # a number scaled or added to
            assert isinstance(old, int | float) and isinstance(c.value, int | float)
            want = old * c.value if c.op is Op.SCALE else old + c.value
        assert new == pytest.approx(want), (c, old, new)
        assert new != old
    changed = {o.split("=")[0] for o in acts.overrides}
    assert _flat(before, changed) == _flat(after, changed)


def _at(doc: dict[str, object], key: str) -> object:
    node: object = doc
    for part in key.split("."):
        assert isinstance(node, dict)
        node = node[part]
    return node


def _flat(doc: object, skip: set[str], prefix: str = "") -> dict[str, object]:
    if isinstance(doc, dict):
        out: dict[str, object] = {}
        for k, v in doc.items():
            out.update(_flat(v, skip, f"{prefix}{k}."))
        return out
    key = prefix[:-1]
    return {} if key in skip else {key: doc}


@pytest.mark.parametrize(("fault", "scenario", "why"), [
    ("gokart.motor_power_x0.5", "line_straight", "no agent has the robot kind gokart"),
    ("line_pid.kp_x0.7", "mpcc_lap", "no agent has the controller line_pid"),
    ("line_pid.ki_x0.7", "line_straight", r"agents.lt0.controller.ki is already 0"),
    ("mpcc.progress_weight_x0.7", "kart_manual", "no agent has the controller mpcc"),
    ("gokart.lidar_dropout_0.3", "mpcc_lap", r"agents.kart0.sensors.lidar.enabled is off"),
    ("gokart.imu_noise_x10", "mpcc_lap", r"nothing reads it: agents.kart0.nodes has no "
                                         r"localization or obstacle_detector"),
    ("gokart.wheel_slip_0.05", "kart_manual", r"nothing reads it"),
    ("hall.floor_friction_x0.8", "line_straight", "the world is a line_lab, not a hall"),
    ("circuit.floor_friction_x0.8", "mpcc_lap", "the world is a hall, not a circuit"),
])
def test_a_fault_with_nothing_to_act_on_is_not_applicable_and_says_why(
        fault: str, scenario: str, why: str) -> None:
    acts = injection(load_scenario(scenario, project=active_project()), BY_NAME[fault])
    assert acts.overrides == ()
    assert re.search(why, acts.why_not), acts.why_not


def test_a_fault_acts_on_every_agent_it_applies_to() -> None:
    """multi_agent has two karts, one of them on mpcc: a kart fault hits both, an mpcc gain
    only the mpcc one."""
    spec = load_scenario("multi_agent", project=active_project())
    karts = sorted(spec.agents)
    kart = injection(spec, BY_NAME["gokart.motor_power_x0.5"]).overrides
    assert [o.split(".")[1] for o in kart] == karts
    mpcc = [a for a in karts if spec.agents[a].controller.type == "mpcc"]
    gain = injection(spec, BY_NAME["mpcc.progress_weight_x0.7"]).overrides
    assert [o.split(".")[1] for o in gain] == mpcc


def test_unknown_fault_or_catalogue_is_bad_input_with_a_suggestion() -> None:
    with pytest.raises(SpecError, match=r"--only line_pid.kp_x07: .*did you mean "
                                        r"'line_pid.kp_x0.7'"):
        select(STANDARD, ["line_pid.kp_x07"])
    with pytest.raises(SpecError, match=r"--catalogue standrd: .*did you mean 'standard'"):
        catalogue("standrd")


@pytest.mark.parametrize(("args", "expected"), [
    (["line_straight", "--only", "line_pid.kp_0.7"], r"did you mean 'line_pid.kp_x0.7'"),
    (["line_straigt"], r"line_straigt"),
    (["line_straight", "--min-score", "2"], r"--min-score 2: expected a fraction"),
])
def test_bad_faults_input_is_one_line_and_exit_2(args: list[str], expected: str,
                                                 tmp_path: Path) -> None:
    proc = kartci("faults", *args, "--out", tmp_path / "out")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert re.search(expected, lines[0]), lines[0]
    assert not list((tmp_path / "out").glob("*@fault=*"))  # nothing ran


def _regressed(base: dict[str, dict[str, float]], head: dict[str, dict[str, float]],
               baseline: dict[str, dict[str, object]]) -> list[str]:
    """The metrics that fail the gate, from the numbers alone: each head value against base's
    with the baseline's tolerance and direction (what `kartci compare` applies)."""
    out = []
    for name, b in base.items():
        entry = baseline[name]
        tol, direction = float(entry["tolerance"]), entry["direction"]  # type: ignore[arg-type]
        d = head[name]["value"] - b["value"]
        if (direction == "lower" and d > tol) or (direction == "higher" and -d > tol) or (
                direction == "equal" and abs(d) > tol):
            out.append(name)
    return sorted(out)


def test_faults_on_a_short_line_run_write_the_matrix_its_metrics_imply(tmp_path: Path) -> None:
    """line_straight cut to 10 s (settling is over by 2 s), under kp x0.7, slower wheels and a
    kart fault: the kart fault is not applicable, and each other cell is caught exactly when a
    metric moved beyond its baseline tolerance, named in the matrix."""
    source = yaml.safe_load(Path("scenarios/line_straight.yaml").read_text(encoding="utf-8"))
    source["duration_s"] = 10.0
    scenario = tmp_path / "line_straight.yaml"
    scenario.write_text(yaml.safe_dump(source), encoding="utf-8")
    out = tmp_path / "out"
    faults = ["line_pid.kp_x0.7", "line_tracker.wheel_lag_x2", "gokart.motor_power_x0.5"]
    proc = kartci("faults", scenario, *(x for f in faults for x in ("--only", f)),
                  "--out", out, "--min-score", "1")
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    cells = {c["fault"]: c for c in summary["cells"]}
    assert cells["gokart.motor_power_x0.5"]["result"] == Cell.NOT_APPLICABLE
    assert cells["gokart.motor_power_x0.5"]["run"] is None
    assert not (out / "line_straight@fault=gokart.motor_power_x0.5").exists()
    baseline = json.loads(Path("baselines/line_straight.json").read_text())["metrics"]
    nominal = json.loads((out / "line_straight" / "metrics.json").read_text())["metrics"]
    caught = 0
    for fault in faults[:2]:
        cell = cells[fault]
        head = json.loads((out / cell["run"] / "metrics.json").read_text())["metrics"]
        moved = _regressed(nominal, head, baseline)
        assert cell["result"] == (Cell.CAUGHT if moved else Cell.MISSED), (cell, moved)
        assert sorted(c.split(" ")[0] for c in cell["caught_by"]) == moved
        caught += bool(moved)
    assert summary["score"] == {"caught": caught, "judged": 2, "score": caught / 2}
    assert summary["scenarios"][0]["caught"] == caught
    page = (out / "faults.html").read_text(encoding="utf-8")
    assert "<svg" in page and "detection matrix" in page
    assert proc.returncode == (0 if caught == 2 else 1), proc.stderr
    assert "detection matrix" in proc.stdout and "line_pid.kp_x0.7" in proc.stdout
