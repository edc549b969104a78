"""Issue 40, item 8: two messages that named the wrong problem. A profile whose pose and
estimate are one topic said that topic "holds no readable pose" (it scores fine alone);
open-loop replay of a foreign log with `--agent commands` was `internal error:
ValidationError`."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from helpers import kartci

from kartci.errors import SpecError
from kartci.logs import McapLogWriter
from kartci.logs.types import header, msg
from kartci.project import current as active_project
from kartci.realdata.profile import check_profile, load_profile

BAG = "turtlebot3_gazebo_cmd_odom_scan.bag"


def _odom_log(path: Path) -> Path:
    """A foreign log (no kartci scenario): a diff-drive robot's odometry and cmd_vel."""
    zero = msg("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=0.0)
    with McapLogWriter(path) as out:
        for k in range(20):
            t_ns = 1_000_000_000 + k * 50_000_000
            pose = msg("geometry_msgs/msg/Pose",
                       position=msg("geometry_msgs/msg/Point", x=0.01 * k, y=0.0, z=0.0),
                       orientation=msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0,
                                       w=1.0))
            odom = msg("nav_msgs/msg/Odometry", header=header(t_ns, "odom"),
                       child_frame_id="base_link",
                       pose=msg("geometry_msgs/msg/PoseWithCovariance", pose=pose,
                                covariance=np.zeros(36)),
                       twist=msg("geometry_msgs/msg/TwistWithCovariance",
                                 twist=msg("geometry_msgs/msg/Twist", linear=zero,
                                           angular=zero), covariance=np.zeros(36)))
            out.write("/robot/odom", odom, t_ns)
            out.write("/robot/cmd_vel", msg("geometry_msgs/msg/Twist", linear=zero,
                                            angular=zero), t_ns)
    return path


def test_pose_and_estimate_on_one_topic_say_so(tmp_path: Path) -> None:
    log = _odom_log(tmp_path / "run.mcap")
    path = tmp_path / "same.yaml"
    path.write_text("pose: {topic: /robot/odom}\nestimate: {topic: /robot/odom}\n")
    with pytest.raises(SpecError) as err:
        check_profile(log, load_profile(path, active_project()))
    assert str(err.value) == (
        f"{log}: profile same: estimate and pose name the same topic /robot/odom: an estimate "
        "judged against its own reference has no error to measure; name the estimate's own "
        "topic, or drop `estimate`")


def test_pose_and_estimate_on_two_chains_of_one_tf_topic_are_fine(tmp_path: Path) -> None:
    path = tmp_path / "tf.yaml"
    path.write_text("pose: {topic: /tf, parent: map, child: base_link}\n"
                    "estimate: {topic: /tf, parent: odom, child: base_link}\n")
    profile = load_profile(path, active_project())
    with pytest.raises(SpecError, match="pose topic /tf is not in the log"):
        check_profile(_odom_log(tmp_path / "run.mcap"), profile)  # not "the same TF chain"


def _one_line(proc: subprocess.CompletedProcess[str]) -> str:
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "internal error" not in lines[0], proc.stderr
    return str(lines[0])


def test_open_loop_commands_on_a_foreign_log_says_what_it_needs(tmp_path: Path) -> None:
    log = _odom_log(tmp_path / "diffdrive.mcap")
    line = _one_line(kartci("replay", log, "--open-loop", "--agent", "commands", "--ns",
                            "robot", "-o", tmp_path / "out"))
    assert line == (f"kartci: error: {log}: --agent commands has required parameters (source) "
                    "that only a kartci run log of a scenario using commands records; replay "
                    "such a log, or choose an agent whose parameters all have defaults")


def test_open_loop_commands_on_the_real_diff_drive_bag(bags: Path, tmp_path: Path) -> None:
    line = _one_line(kartci("replay", bags / BAG, "--open-loop", "--agent", "commands", "--ns",
                            "robot", "-o", tmp_path / "out"))
    assert "--agent commands has required parameters (source)" in line
