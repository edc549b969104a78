"""A stack of two unmodified rclpy nodes over Fast DDS (examples/ros2_stack: `odom_relay_node.py`
relays the odometry, `pure_pursuit_node.py` drives from the relay), sensor-data QoS (best effort)
on every topic and the track latched (transient-local): the lockstep waits for the relay, the
graph settles before t = 0, kartci's endpoints offer and ask what the stack's do, so identical
runs give identical metrics with no late tick and tick 0 is never lost. A relay whose
best-effort output a reliable subscription can never read is an error naming both QoS. The
default tier runs it twice for 1 s; the full tier ten times for 10 s. A first tick that gets
no answer starts the stack again and gives the clean start's run. Skipped, saying why,
where no ROS 2 Python can be made."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import ROOT, kartci

from bridge.dds.ros2python import ros_python_or_skip

EXAMPLE = ROOT / "examples" / "ros2_stack"


def two_nodes(duration_s: float, relay_qos: str = "sensor_data",
              driver_qos: str = "sensor_data", track: str = "/kartci/track") -> dict[str, Any]:
    """The example's scenario with the relay and the driver, as a launch file starts them
    (`track`: the driver's track topic, a shell word)."""
    spec: dict[str, Any] = yaml.safe_load(
        (EXAMPLE / "scenarios" / "dds_pure_pursuit.yaml").read_text())
    spec["duration_s"] = duration_s
    spec["criteria"] = {}
    ros = "{ros_python}"
    args = '--ros-args -r "__ns:=/{namespace}" -p use_sim_time:=true'
    spec["agents"]["kart0"]["controller"]["command"] = [
        "sh", "-c",
        f"{ros} odom_relay_node.py {args} -p qos:={relay_qos} & exec {ros} pure_pursuit_node.py "
        f"{args} -r track:={track} -r odom:=odom_relay -p speed_mps:=5.0 "
        f"-p qos:={driver_qos} -p track_latched:=true"]
    return spec


@pytest.fixture
def example(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, dds_alone: None) -> Path:
    """A copy of the example project with the ROS 2 Python named."""
    monkeypatch.setenv("KARTCI_ROS2_PYTHON", str(ros_python_or_skip()))
    proj = tmp_path / "ros2_stack"
    shutil.copytree(EXAMPLE, proj, ignore=shutil.ignore_patterns("reports", "baselines"))
    for old in (proj / "scenarios").iterdir():
        old.unlink()
    return proj


def check(proj: Path, duration_s: float, runs: int) -> None:
    names = [f"two_{k}" for k in range(runs)]
    for name in names:
        (proj / "scenarios" / f"{name}.yaml").write_text(yaml.safe_dump(two_nodes(duration_s)))
    out = proj / "out"
    p = kartci("run", "-j", "2", "--out", out, "--no-strict", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "lockstep waits for /kart0/cmd_vel after clock, /kart0/odom_relay after sensors" \
        in p.stderr
    found = {n: json.loads((out / n / "metrics.json").read_text()) for n in names}
    assert {n: d["timing"]["late_commands"]["value"] for n, d in found.items()} == dict.fromkeys(
        names, 0)
    first = found[names[0]]["metrics"]
    assert first["progress_m"]["value"] > 0.2 * duration_s  # it drives from tick 0's odometry
    assert first["stalled_s"]["value"] <= 0.02
    assert {n: sorted(k for k in first if d["metrics"][k] != first[k])
            for n, d in found.items()} == {n: [] for n in names}


def test_two_rclpy_nodes_with_best_effort_qos_give_the_same_metrics(example: Path) -> None:
    check(example, 1.0, 2)


@pytest.mark.long(reason="ten 10 s runs of a two-node rclpy stack")
def test_two_rclpy_nodes_give_the_same_metrics_ten_runs(example: Path) -> None:
    check(example, 10.0, 10)


def test_a_qos_pair_that_never_matches_names_both_sides(example: Path) -> None:
    (example / "scenarios" / "mismatch.yaml").write_text(yaml.safe_dump(
        two_nodes(0.2, relay_qos="sensor_data", driver_qos="default")))
    p = kartci("run", "--out", example / "out", "--no-strict", cwd=example)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "Traceback" not in p.stdout + p.stderr
    error = json.loads((example / "out" / "summary.json").read_text())["scenarios"][
        "mismatch"]["error"]
    assert ("/kart0/odom_relay: /kart0/odom_relay's publisher offers best-effort, volatile, "
            "/kart0/pure_pursuit's subscription asks reliable, volatile; they never match "
            "(reliability)") in error


def test_a_first_tick_without_answer_starts_the_stack_again(example: Path) -> None:
    """The first start's driver waits for a track nobody publishes (as a node that has not
    found another yet never answers): kartci stops it, starts the stack again, makes tick 0
    anew, and the run is the run a clean start gives, metric for metric."""
    clean = two_nodes(1.0)
    retried = two_nodes(1.0, track="$T")
    retried["agents"]["kart0"]["controller"]["command"][2] = (
        "if [ -e .started ]; then T=/kartci/track; else touch .started; T=/nowhere; fi; "
        + retried["agents"]["kart0"]["controller"]["command"][2])
    for spec in (clean, retried):
        spec["agents"]["kart0"]["controller"].update(
            tick_timeout_s=2.0, waits_for=[{"topic": "/nowhere", "count": 0}])
    (example / "scenarios" / "clean.yaml").write_text(yaml.safe_dump(clean))
    (example / "scenarios" / "retried.yaml").write_text(yaml.safe_dump(retried))
    out = example / "out"
    p = kartci("run", "--out", out, "--no-strict", cwd=example)
    assert p.returncode == 0, p.stdout + p.stderr
    assert ("kart0: no answer to the first tick within 2 s (waiting for /kart0/cmd_vel): its "
            "nodes may not have found each other yet; starting the stack again (start 2 of 3, "
            "graph settling 0.6 s)") in p.stderr
    assert p.stderr.count("starting the stack again") == 1
    assert (out / "retried" / "kart0.external.start1.stderr.log").is_file()
    assert not (out / "clean" / "kart0.external.start1.stderr.log").exists()
    found = {n: json.loads((out / n / "metrics.json").read_text()) for n in ("clean", "retried")}
    assert found["retried"]["timing"]["late_commands"]["value"] == 0
    assert found["retried"]["metrics"] == found["clean"]["metrics"]
    assert json.loads((out / "retried" / "kart0.dds_round_trip.log").read_text())["starts"] == 2
