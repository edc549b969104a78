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
    assert summary["score"] == {"caught": caught, "judged": 2, "no_effect": 0,
                                "score": caught / 2}
    assert summary["scenarios"][0]["caught"] == caught
    page = (out / "faults.html").read_text(encoding="utf-8")
    assert "<svg" in page and "detection matrix" in page
    assert proc.returncode == (0 if caught == 2 else 1), proc.stderr
    assert "detection matrix" in proc.stdout and "line_pid.kp_x0.7" in proc.stdout


def _three_faulted_runs(tmp_path: Path) -> Path:
    """Runs q (settle_time_s 0.84 s) and q@a, q@b, q@c (+0.01, +0.1, +0.3 s) with a baseline
    tolerance of 0.2 s; returns the baselines folder."""
    base = tmp_path / "baselines"
    base.mkdir()
    (base / "q.json").write_text(json.dumps({"scenario": "q", "metrics": {
        "settle_time_s": {"value": 0.84, "tolerance": 0.2, "direction": "lower", "unit": "s"}}}))
    for label, value in (("q", 0.84), ("q@a", 0.85), ("q@b", 0.94), ("q@c", 1.14)):
        (tmp_path / label).mkdir()
        (tmp_path / label / "metrics.json").write_text(json.dumps(
            {"metrics": {"settle_time_s": {"value": value, "unit": "s"}}}))
    return base


def test_a_fault_that_moves_no_metric_beyond_its_resolution_has_no_effect_and_is_not_scored(
        tmp_path: Path) -> None:
    """settle_time_s is registered (default tolerance 0.5 s at 0.84 s, so a resolution of
    0.05 s) with a baseline tolerance of 0.2 s: +0.01 s is float-digit noise (no effect),
    +0.1 s a real move the gate lets pass (missed), +0.3 s caught."""
    from kartci.app.faults import Judgement, judge, score
    from kartci.verdict import ScenarioResult

    base = _three_faulted_runs(tmp_path)
    runs = {label: ScenarioResult(label, "") for label in ("q", "q@a", "q@b", "q@c")}
    cells = [judge(Judgement(f"f.{x}", "q", Cell.MISSED, label=f"q@{x}"), runs["q"],
                   runs[f"q@{x}"], tmp_path, base) for x in "abc"]
    assert [c.cell for c in cells] == [Cell.NO_EFFECT, Cell.MISSED, Cell.CAUGHT]
    assert "0.2 of its resolution" in cells[0].why
    got = score(cells)
    assert (got.caught, got.judged, got.no_effect) == (1, 2, 1)


def test_rejudge_gives_the_matrix_of_todays_tolerances_without_running(tmp_path: Path) -> None:
    """The three runs above judged at a tolerance of 0.2 s, then again after it is narrowed
    to 0.05 s: q@b is caught now, q@a still has no effect; a not-applicable cell stays."""
    from kartci.app.faults import Judgement, Matrix, judge, rejudge, to_json
    from kartci.verdict import ScenarioResult

    base = _three_faulted_runs(tmp_path)
    entries = [Entry("line_pid", Scope.CONTROLLER, Fault("kp_x0.7", "", ())),
               Entry("line_pid", Scope.CONTROLLER, Fault("ki_x0.7", "", ())),
               Entry("line_tracker", Scope.ROBOT, Fault("wheel_lag_x2", "", ())),
               Entry("gokart", Scope.ROBOT, Fault("brake_x0.5", "", ()))]
    cells = [judge(Judgement(e.name, "q", Cell.MISSED, label=f"q@{x}"), ScenarioResult("q", ""),
                   ScenarioResult(f"q@{x}", ""), tmp_path, base)
             for e, x in zip(entries, "abc", strict=False)]
    cells.append(Judgement(entries[3].name, "q", Cell.NOT_APPLICABLE, why="no kart"))
    (tmp_path / "summary.json").write_text(json.dumps(to_json(
        Matrix(entries, ["q"], cells, {"q": "pass"}), "kartci faults q", "standard", None)))
    doc = json.loads((base / "q.json").read_text())
    doc["metrics"]["settle_time_s"]["tolerance"] = 0.05
    (base / "q.json").write_text(json.dumps(doc))
    proc = kartci("faults", "--rejudge", "--out", tmp_path, "--baselines", base)
    assert proc.returncode == 0, proc.stderr
    after = json.loads((tmp_path / "summary.json").read_text())
    assert [c["result"] for c in after["cells"]] == ["no effect", "caught", "caught",
                                                    "not applicable"]
    assert after["score"] == {"caught": 2, "judged": 2, "no_effect": 1, "score": 1.0}
    assert "1 cells with no effect" in proc.stdout
    assert rejudge(tmp_path, base).matrix.score.caught == 2
    bad = kartci("faults", "q", "--rejudge", "--out", tmp_path, "--baselines", base)
    assert bad.returncode == 2 and "give it no scenarios" in bad.stderr


def test_shards_of_a_faults_run_merge_into_one_matrix(tmp_path: Path) -> None:
    """Two short scenarios dealt to two shards (each with its nominal and faulted run), merged
    by `kartci merge`: one matrix with both scenarios, their cells as each shard judged them,
    and the run folders copied beside it."""
    names = []
    for name, duration in (("line_straight", 10.0), ("line_sprint", 6.5)):
        source = yaml.safe_load(Path(f"scenarios/{name}.yaml").read_text(encoding="utf-8"))
        source["duration_s"] = duration
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(source), encoding="utf-8")
        names.append(tmp_path / f"{name}.yaml")
    shards = [tmp_path / "s1", tmp_path / "s2"]
    for i, shard in enumerate(shards, 1):
        proc = kartci("faults", *names, "--only", "line_pid.kp_x0.7", "--shard", f"{i}/2",
                      "--out", shard)
        assert proc.returncode == 0, proc.stderr
    parts = [json.loads((s / "summary.json").read_text()) for s in shards]
    assert sorted(len(p["scenarios"]) for p in parts) == [1, 1]
    merged = tmp_path / "merged"
    proc = kartci("merge", *shards, "--out", merged)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((merged / "summary.json").read_text())
    assert [s["name"] for s in doc["scenarios"]] == ["line_sprint", "line_straight"]
    assert sorted((c["scenario"], c["result"]) for c in doc["cells"]) == sorted(
        (c["scenario"], c["result"]) for p in parts for c in p["cells"])
    for c in doc["cells"]:
        assert (merged / c["run"] / "metrics.json").is_file()
        assert (merged / c["scenario"] / "metrics.json").is_file()
    assert (merged / "faults.html").is_file() and "detection matrix" in proc.stdout
    mixed = kartci("merge", shards[0], tmp_path / "nothing", "--out", tmp_path / "m2")
    assert mixed.returncode == 2 and "mix" in mixed.stderr
