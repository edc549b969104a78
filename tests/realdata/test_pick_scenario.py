"""`kartci simreal` without a profile or --scenario: the scenario is picked from the log's
command type (the robot kind replayed from it), said in one line with why; a log that does not
tell is one line and exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import kartci
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.realdata.profile import CommandRole, PoseRole, Profile
from kartci.realdata.simreal import guess_scenario, sim_setup

TWIST = "geometry_msgs/msg/Twist"
ACKERMANN = "ackermann_msgs/msg/AckermannDriveStamped"


def _profile(commands: bool = True) -> Profile:
    return Profile(name="log", pose=PoseRole(topic="/odom"),
                   commands=CommandRole(topic="/cmd") if commands else None)


@pytest.mark.parametrize(("msgtype", "scenario", "why"), [
    (TWIST, "diffdrive_simreal", "simulating diffdrive_simreal (robot kind line_tracker): the "
     "commands /cmd are geometry_msgs/msg/Twist, velocity commands a differential-drive base "
     "turns into wheel speeds (--scenario to choose another)"),
    ("geometry_msgs/msg/TwistStamped", "diffdrive_simreal", None),
    (ACKERMANN, "kart_simreal", "simulating kart_simreal (robot kind gokart): the commands /cmd "
     f"are {ACKERMANN}, commands only gokart is replayed from (--scenario to choose another)"),
    ("kartci_msgs/msg/KartCommand", "kart_simreal", None),
])
def test_the_command_type_picks_the_scenario(msgtype: str, scenario: str,
                                             why: str | None) -> None:
    name, said = guess_scenario(_profile(), {"pose": "nav_msgs/msg/Odometry",
                                             "commands": msgtype})
    assert name == scenario
    if why is not None:
        assert said == why
    setup = sim_setup(_profile(), None, [], active_project(), {"commands": msgtype})
    assert setup.scenario.name == scenario and setup.picked == said


def test_a_named_scenario_is_not_guessed() -> None:
    setup = sim_setup(_profile(), "kart_simreal", [], active_project(), {"commands": TWIST})
    assert setup.scenario.name == "kart_simreal" and setup.picked == ""


@pytest.mark.parametrize(("commands", "msgtype", "words"), [
    (False, None, "the log has no single command topic to replay"),
    (True, "sensor_msgs/msg/Joy", "the commands /cmd are sensor_msgs/msg/Joy, and no robot kind "
     "is replayed from it"),
])
def test_a_log_that_does_not_tell_is_one_line(commands: bool, msgtype: str | None,
                                              words: str) -> None:
    types = {"commands": msgtype} if msgtype else {}
    with pytest.raises(SpecError) as err:
        guess_scenario(_profile(commands), types)
    text = str(err.value)
    assert "\n" not in text and words in text
    assert text.endswith("give --scenario, or `robot: {kind: ...}` or `scenario:` in a profile")


def _write_log(path: Path, command: str) -> None:
    """2 s of a base driving an arc: Odometry at 20 Hz and its commands (Twist or Ackermann)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        cmd = w.add_connection("/cmd", command, typestore=store)
        for k in range(40):
            ns = 10**9 + k * 50_000_000
            yaw = k * 0.05 * 0.2
            stamp = t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            header = t["std_msgs/msg/Header"](stamp=stamp, frame_id="odom")
            vec = t["geometry_msgs/msg/Vector3"]
            twist = t["geometry_msgs/msg/Twist"](linear=vec(x=0.2, y=0.0, z=0.0),
                                                 angular=vec(x=0.0, y=0.0, z=0.2))
            pose = t["geometry_msgs/msg/Pose"](
                position=t["geometry_msgs/msg/Point"](x=np.sin(yaw), y=1 - np.cos(yaw), z=0.0),
                orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=np.sin(yaw / 2),
                                                              w=np.cos(yaw / 2)))
            m = t["nav_msgs/msg/Odometry"](
                header=header, child_frame_id="base_link",
                pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose,
                                                               covariance=np.zeros(36)),
                twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist,
                                                                 covariance=np.zeros(36)))
            w.write(odom, ns, store.serialize_cdr(m, m.__msgtype__))
            c: object = twist
            if command == ACKERMANN:
                c = t[ACKERMANN](header=header, drive=t["ackermann_msgs/msg/AckermannDrive"](
                    steering_angle=0.1, steering_angle_velocity=0.0, speed=0.2,
                    acceleration=0.0, jerk=0.0))
            w.write(cmd, ns, store.serialize_cdr(c, command))


def test_simreal_without_a_profile_says_what_it_picked(tmp_path: Path) -> None:
    log = tmp_path / "base"
    _write_log(log, TWIST)
    (tmp_path / "bl").mkdir()
    r = kartci("simreal", log, "--out", tmp_path / "out", "--baselines", tmp_path / "bl",
               "--window-s", "1")
    assert r.returncode == 0, r.stderr
    assert ("kartci: simulating diffdrive_simreal (robot kind line_tracker): the commands /cmd "
            "are geometry_msgs/msg/Twist") in r.stderr
    assert (tmp_path / "out" / "base_simreal" / "metrics.json").is_file()


def test_simreal_on_a_log_that_does_not_tell_is_exit_2(tmp_path: Path) -> None:
    log = tmp_path / "base"
    _write_log(log, TWIST)
    profile = tmp_path / "p.yaml"
    profile.write_text("name: p\npose: {topic: /odom}\n")
    r = kartci("simreal", log, "-p", profile, "--out", tmp_path / "out")
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert r.stderr.startswith("kartci: error: profile p: cannot tell which robot to simulate")
