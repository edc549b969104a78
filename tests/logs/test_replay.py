"""`kartci replay`: inputs recorded by other programs drive the kart in closed loop."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore

from kartci.logs import messages, tables
from kartci.project import BUILTIN_MODELS

BUILTIN_JOY = BUILTIN_MODELS / "gokart" / "joy"


def kartci(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kartci.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def _ros1_joy_bag(path: Path) -> None:
    """A PS4 Joy stream as the ROS 1 `joy` node would record it: R2 held for 1.5 s, then
    braking with L2, written with rosbags (not kartci), timestamps in 2023."""
    ts = get_typestore(Stores.ROS1_NOETIC)
    t0 = 1_700_000_000_000_000_000
    with Ros1Writer(path) as w:
        conn = w.add_connection("/joy", "sensor_msgs/msg/Joy", typestore=ts)
        for k in range(300):  # 50 Hz, 6 s
            t = t0 + k * 20_000_000
            axes = np.array([0, 0, 1, 0, 0, 1, 0, 0], dtype=np.float32)
            if k < 75:
                axes[5] = -1.0  # R2 fully pressed
            else:
                axes[2] = -1.0  # L2 fully pressed
            hdr = ts.types["std_msgs/msg/Header"](
                seq=k, stamp=ts.types["builtin_interfaces/msg/Time"](sec=t // 10**9,
                                                                     nanosec=t % 10**9),
                frame_id="joy")
            joy = ts.types["sensor_msgs/msg/Joy"](header=hdr, axes=axes,
                                                  buttons=np.zeros(13, dtype=np.int32))
            w.write(conn, t, ts.serialize_ros1(joy, "sensor_msgs/msg/Joy"))


def _summary(out: Path) -> dict[str, float]:
    doc = json.loads((out / "kart_replay" / "metrics.json").read_text())
    return {k: v["value"] for k, v in doc["metrics"].items()}


@pytest.mark.long(reason="replays logs through full runs")
def test_replay_a_ros1_joy_bag_written_by_rosbags(tmp_path: Path) -> None:
    bag = tmp_path / "drive.bag"
    _ros1_joy_bag(bag)
    out = tmp_path / "out"
    p = kartci("replay", bag, "--set", "duration_s=8", "--out", out)
    assert p.returncode == 0, p.stdout + p.stderr
    m = _summary(out)
    # 1.5 s at up to 5 m/s^2 (the 95 Nm motors allow less), then 8 m/s^2 braking to a stop
    assert 4.0 < m["progress_m"] < 12.0
    assert 3.0 < m["max_speed_mps"] <= 7.5
    assert m["collisions"] == 0
    t = tables(out / "kart_replay" / "run.mcap", ["/kart0/joy", "/kart0/odom"])
    assert len(t["/kart0/joy"]) == 300  # the replayed stream is in the run log
    assert t["/kart0/joy"]["t"].iloc[0] == 0.0  # re-based onto sim time
    assert abs(t["/kart0/odom"]["vx"].iloc[-1]) < 0.05  # braked to a stop


@pytest.mark.long(reason="replays logs through full runs")
def test_replay_twist_stamped_from_a_rosbag2(tmp_path: Path) -> None:
    """2 m/s and 0.4 rad/s (a 5 m circle) as TwistStamped in a rosbag2 (sqlite3) folder."""
    ts = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "cmd_bag"
    with Ros2Writer(bag, version=8) as w:
        conn = w.add_connection("/cmd_vel", "geometry_msgs/msg/TwistStamped", typestore=ts)
        for k in range(400):  # 50 Hz, 8 s
            t = 5_000_000_000 + k * 20_000_000
            tw = ts.types["geometry_msgs/msg/Twist"](
                linear=ts.types["geometry_msgs/msg/Vector3"](x=2.0, y=0.0, z=0.0),
                angular=ts.types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.4))
            hdr = ts.types["std_msgs/msg/Header"](
                stamp=ts.types["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9),
                frame_id="base_link")
            msg = ts.types["geometry_msgs/msg/TwistStamped"](header=hdr, twist=tw)
            w.write(conn, t, ts.serialize_cdr(msg, "geometry_msgs/msg/TwistStamped"))
    out = tmp_path / "out"
    p = kartci("replay", bag, "--set", "duration_s=8", "--out", out)
    assert p.returncode == 0, p.stdout + p.stderr
    odom = tables(out / "kart_replay" / "run.mcap", ["/kart0/odom"])["/kart0/odom"]
    late = odom[odom["t"] > 5.0]
    assert late["vx"].mean() == pytest.approx(2.0, abs=0.2)
    # open-loop steering from the bicycle relation through the kart's drive-by-wire: within 25 %
    assert late["wz"].mean() == pytest.approx(0.4, rel=0.25)


@pytest.mark.long(reason="replays logs through full runs")
def test_replay_the_real_twist_stamped_fixture(bags: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    p = kartci("replay", bags / "cmd_vel_twiststamped.mcap", "--set", "duration_s=2",
               "--out", out)
    assert p.returncode == 0, p.stdout + p.stderr
    sent = [m for _, _, m in messages(out / "kart_replay" / "run.mcap", ["/kart0/cmd_vel"])]
    assert len(sent) == 101  # republished once per 20 ms control period, on the standard topic
    assert all(m.twist.linear.x == 0 for m in sent)  # the recording commands rest
    assert _summary(out)["progress_m"] == pytest.approx(0.0, abs=0.05)


def test_a_log_without_a_drive_topic_is_one_clear_line(bags: Path, tmp_path: Path) -> None:
    p = kartci("replay", bags / "jackal_imu_odom.bag", "--out", tmp_path)
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr
    assert "Joy or drive-command topic" in lines[0] and "/imu/data" in lines[0]


def test_a_named_topic_that_is_missing(tmp_path: Path) -> None:
    bag = tmp_path / "drive.bag"
    _ros1_joy_bag(bag)
    p = kartci("replay", bag, "--topic", "/nope", "--out", tmp_path / "o")
    assert p.returncode == 2 and "topic /nope" in p.stderr


def _xbox_bag(path: Path, seconds: float = 6.0) -> None:
    """An Xbox pad as joy_linux reports it (8 axes, 11 buttons), RT held, plus a String topic."""
    ts = get_typestore(Stores.ROS1_NOETIC)
    t0 = 1_700_000_000_000_000_000
    with Ros1Writer(path) as w:
        conn = w.add_connection("/joy", "sensor_msgs/msg/Joy", typestore=ts)
        chat = w.add_connection("/chatter", "std_msgs/msg/String", typestore=ts)
        for k in range(int(seconds * 50)):
            t = t0 + k * 20_000_000
            axes = np.array([0, 0, 1, 0, 0, -1, 0, 0], dtype=np.float32)  # RT pressed
            hdr = ts.types["std_msgs/msg/Header"](
                seq=k, stamp=ts.types["builtin_interfaces/msg/Time"](sec=t // 10**9,
                                                                     nanosec=t % 10**9),
                frame_id="joy")
            joy = ts.types["sensor_msgs/msg/Joy"](header=hdr, axes=axes,
                                                  buttons=np.zeros(11, dtype=np.int32))
            w.write(conn, t, ts.serialize_ros1(joy, "sensor_msgs/msg/Joy"))
            w.write(chat, t, ts.serialize_ros1(ts.types["std_msgs/msg/String"](data="hi"),
                                               "std_msgs/msg/String"))


@pytest.mark.long(reason="replays logs through full runs")
def test_an_xbox_pad_with_its_mapping_and_a_log_longer_than_the_scenario(tmp_path: Path) -> None:
    bag = tmp_path / "xbox.bag"
    _xbox_bag(bag)
    out = tmp_path / "out"
    p = kartci("replay", bag, "--topic", "/joy", "--mapping", "xbox", "--set", "duration_s=3",
               "--out", out)
    assert p.returncode == 0, p.stdout + p.stderr
    assert _summary(out)["max_speed_mps"] > 1.0  # RT drives the kart
    assert "warning" in p.stderr and "are not replayed" in p.stderr  # the log runs 6 s
    warnings = json.loads((out / "summary.json").read_text())["scenarios"]["kart_replay"][
        "warnings"]
    assert "runs to 6.0 s but the scenario stops at 3 s" in warnings[0]


@pytest.mark.long(reason="replays logs through full runs")
def test_a_pad_that_does_not_fit_its_mapping_is_one_clear_line(tmp_path: Path) -> None:
    bag = tmp_path / "xbox.bag"
    _xbox_bag(bag, seconds=1.0)
    p = kartci("replay", bag, "--topic", "/joy", "--mapping", "ps4", "--out", tmp_path / "o")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1
    assert "8 axes and 11 buttons" in lines[0] and "expects 8 axes and 13 buttons" in lines[0]
    assert "xbox" in lines[0]


def test_a_topic_of_the_wrong_type_says_so(tmp_path: Path) -> None:
    bag = tmp_path / "xbox.bag"
    _xbox_bag(bag, seconds=1.0)
    p = kartci("replay", bag, "--topic", "/chatter", "--out", tmp_path / "o")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert "/chatter is std_msgs/msg/String, which cannot drive a kart" in p.stderr


def test_a_projects_own_mapping_is_found_and_listed(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    from kartci import project
    from kartci.errors import SpecError
    from kartci.robots.gokart.joy import load_mapping

    joy = tmp_path / "models" / "gokart" / "joy"
    joy.mkdir(parents=True)
    text = (BUILTIN_JOY / "xbox.yaml").read_text().replace("Xbox controller", "our pad")
    (joy / "our_pad.yml").write_text(text)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "kartci.toml").write_text("")
    project.activate(None)
    models = project.current().model_path
    assert load_mapping("our_pad", models).name == "our pad"
    assert load_mapping(str(joy / "our_pad.yml"), models).buttons == 11  # by path
    with pytest.raises(SpecError, match=r"known: .*our_pad.*ps4.*xbox"):
        load_mapping("qqqqqq", models)
