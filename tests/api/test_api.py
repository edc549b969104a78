"""The Python API: `kartci.run`, `kartci.Session` (a run stepped by its caller, of which
`simulate` is one client), agents handed in as objects, and a cheap `import kartci`."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import kartci
from kartci import KartciError, Session, SpecError, load_scenario
from kartci.logs import header, msg, tables
from kartci.sim import simulate
from kartci.sim.session import REPLACED_TOPIC

QUICK = ("duration_s=3", "metrics.line_tracking.transient_s=1")


class Bang:
    """A line tracker's bang-bang controller, written the way a team would (the `Agent`
    docstring's example)."""

    period_s = 0.06
    inputs = ("line_sensor",)

    def __init__(self) -> None:
        self.left = self.right = 0.0
        self.ticks: list[int] = []

    def on_message(self, topic: str, message: Any) -> None:
        self.left, self.right = message.left, message.right

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        self.ticks.append(t_ns)
        turn = 0.5 if self.left > self.right else -0.5
        return [("wheel_cmd", msg("sensor_msgs/msg/JointState",
                                  header=header(t_ns, "base_link"), name=[],
                                  position=np.zeros(0), effort=np.zeros(0),
                                  velocity=np.array([3.0 + turn, 3.0 - turn])))]


def test_public_names_resolve_and_are_documented() -> None:
    for name in kartci.__all__:
        obj = getattr(kartci, name)
        assert (obj.__doc__ or "").strip(), f"kartci.{name} has no docstring"
    for name in kartci.core.__all__:
        assert getattr(kartci.core, name) is not None
    assert {"Controller", "MetricSet", "register"} <= set(kartci.core.__all__)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        kartci.nope  # noqa: B018


def test_import_kartci_is_cheap() -> None:
    """No simulator, solver, tables or plots (nor pydantic) at `import kartci`."""
    code = ("import sys, kartci; heavy = ('pybullet', 'casadi', 'pandas', 'matplotlib', "
            "'numpy', 'pydantic', 'scipy'); print([m for m in heavy if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_stepping_a_session_gives_simulates_log_byte_for_byte(tmp_path: Path) -> None:
    spec = load_scenario("line_straight", ["duration_s=0.5"])
    info = simulate(spec, tmp_path / "simulate.mcap")
    seen: list[tuple[str, Any]] = []
    with Session(spec, tmp_path / "session.mcap") as s:
        r = s.reset()
        assert (r.step, r.t_ns) == (0, 0)
        assert r.messages[0][0] == "/kartci/scenario"
        seen += r.messages
        while not r.done:
            r = s.step()
            assert r.t_ns == r.step * 2_000_000  # dt 2 ms: one physics step per call
            for topic, m in r.messages:
                if topic == "/lt0/odom":  # every message of a step is stamped at its time
                    assert m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == r.t_ns
            seen += r.messages
        assert s.info() == info
    assert r.step == 250 and r.t_s == pytest.approx(0.5) and not r.finished_course
    assert len(seen) == info.messages
    assert (tmp_path / "session.mcap").read_bytes() == (tmp_path / "simulate.mcap").read_bytes()


def test_a_session_without_a_log_still_steps_and_refuses_misuse(tmp_path: Path) -> None:
    spec = load_scenario("line_straight", ["duration_s=0.01"])
    s = Session(spec)
    with pytest.raises(KartciError, match="call reset"):
        s.step()
    r = s.reset()
    while not r.done:
        r = s.step()
    with pytest.raises(KartciError, match="the run is over"):
        s.step()
    with pytest.raises(KartciError, match="runs once"):
        s.reset()
    s.close()
    s.close()
    assert not list(tmp_path.iterdir())


def test_a_session_closed_early_keeps_the_shorter_log(tmp_path: Path) -> None:
    spec = load_scenario("line_straight", ["duration_s=10"])
    with Session(spec, tmp_path / "run.mcap") as s:
        s.reset()
        for _ in range(100):
            s.step()
    odom = tables(tmp_path / "run.mcap", ["/lt0/odom"])["/lt0/odom"]
    assert odom["t"].iloc[-1] == pytest.approx(0.2)


def test_an_agent_object_drives_and_the_log_says_so(tmp_path: Path) -> None:
    bang = Bang()
    result = kartci.run("line_straight", overrides=QUICK, agents={"lt0": bang},
                        out=tmp_path, baselines=tmp_path / "none")
    assert len(bang.ticks) == 51  # every 0.06 s from 0 to 3 s
    assert result.replaced_agents == {"lt0": "test_api.Bang"}
    t = tables(result.log, ["/kartci/scenario", REPLACED_TOPIC, "/lt0/controller/state"])
    recorded = json.loads(t["/kartci/scenario"]["data"].iloc[0])
    assert recorded["agents"]["lt0"]["controller"]["type"] == "line_pid"  # as written...
    assert json.loads(t[REPLACED_TOPIC]["data"].iloc[0]) == {"lt0": "test_api.Bang"}  # ...but
    assert "/lt0/controller/state" not in t  # line_pid never ran
    assert "controller replaced by test_api.Bang" in result.table()
    run_json = json.loads((result.folder / "run.json").read_text())
    assert run_json["replaced_agents"] == {"lt0": "test_api.Bang"}



@pytest.mark.long(reason="kartci runs end to end")
def test_a_run_whose_agent_sends_unnamed_wheel_commands_reports(tmp_path: Path) -> None:
    """`Bang` sends wheel speeds without joint names (the robot reads them in order): the
    report and the baseline's reference trace draw what they can (the commanded speeds they
    cannot attribute are left out) instead of failing on a missing `left_wheel_hinge` column."""
    out, baselines = tmp_path / "out", tmp_path / "baselines"
    baselines.mkdir()
    kartci.run("line_straight", overrides=QUICK, agents={"lt0": Bang()}, out=out,
               baselines=baselines)

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "kartci.cli", *args, str(out),
                               "--baselines", str(baselines)],
                              capture_output=True, text=True, timeout=300)

    r = cli("report", "--no-strict")
    assert r.returncode == 1, r.stdout + r.stderr  # 3 s do not complete the line: judged
    static = (out / "report-static.html").read_text(encoding="utf-8")
    assert "driven wheel speeds (measured)" in static  # the commands: not attributable
    r = cli("baseline", "update", "--replicas", "0")
    assert r.returncode == 0, r.stdout + r.stderr
    assert (baselines / "traces" / "line_straight.json").is_file()


class NoStep:
    period_s = 0.06
    inputs = ("line_sensor",)

    def on_message(self, topic: str, message: Any) -> None:
        pass


class OddPeriod(Bang):
    period_s = 0.005


@pytest.mark.parametrize(("agents", "error"), [
    ({"lt0": NoStep()}, r"agents\['lt0'\] \(test_api.NoStep\): lacks step; an agent needs"),
    ({"lt0": OddPeriod()}, r"period_s 0.005 s is not a whole multiple of physics.dt_s 0.002"),
    ({"lt1": Bang()}, r"has no agent 'lt1' \(did you mean 'lt0'\?\)"),
])
def test_an_agent_object_that_is_no_agent_is_a_clear_error(
        agents: dict[str, object], error: str, tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=error):
        kartci.run("line_straight", overrides=QUICK, agents=agents, out=tmp_path)
    assert not (tmp_path / "line_straight" / "run.mcap").exists()


def test_a_crashing_agent_object_raises_its_own_error_and_leaves_no_log(tmp_path: Path) -> None:
    class Crash(Bang):
        def step(self, t_ns: int) -> list[tuple[str, Any]]:
            if t_ns > 10**9:
                raise ZeroDivisionError("my bug")
            return super().step(t_ns)

    with pytest.raises(ZeroDivisionError, match="my bug"):
        simulate(load_scenario("line_straight", ["duration_s=2"]), tmp_path / "run.mcap",
                 agents={"lt0": Crash()})
    assert not list(tmp_path.iterdir())


def test_run_returns_metrics_with_units_verdicts_and_criteria(tmp_path: Path,
                                                              baselines: Path) -> None:
    first = kartci.run("line_straight", overrides=QUICK, out=tmp_path / "a",
                       baselines=baselines)
    assert first.metrics["cross_track_rms_m"].unit == "m"
    assert 0 < first.value("cross_track_rms_m") < 0.001
    assert {v.status.value for v in first.verdicts} == {"new"} and first.baseline is None
    assert first.criteria and not first.passed  # completion >= 0.99 fails in 3 s
    assert first.log.is_file() and first.sim_time_s == pytest.approx(3.0)
    with pytest.raises(KeyError, match="did you mean 'completion'"):
        first.value("completoin")

    (baselines / "line_straight.json").write_text(json.dumps({"metrics": {
        "mean_speed_mps": {"value": 0.5, "unit": "m/s", "tolerance": 0.01,
                           "direction": "higher"}}}))
    spec = load_scenario("line_straight")  # a Scenario object, overridden like a name
    again = kartci.run(spec, overrides=[*QUICK, "criteria={}"], out=tmp_path / "b",
                       baselines=baselines)
    speed = next(v for v in again.verdicts if v.name == "mean_speed_mps")
    assert speed.status.value == "regressed" and not again.passed
    assert again.value("mean_speed_mps") == first.value("mean_speed_mps")  # deterministic
    assert "mean_speed_mps" in again.table() and "regressed" in again.table()


def test_a_run_shorter_than_its_transient_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"transient_s is 8 s but the run lasts 3 s "
                                        r"\(duration_s 3 s\)"):
        kartci.run("line_straight", overrides=["duration_s=3"], out=tmp_path)
