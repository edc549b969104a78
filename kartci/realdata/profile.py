"""Import profiles: which topics of a foreign log play which of kartci's roles.

A profile is a small YAML file (see `profiles/`): the robot's pose or odometry (the reference),
optionally a pose estimate to judge against it, the command stream, IMU and lidar, the robot
kind with its parameters (for `simreal` and `calibrate`) and the track, if there is one."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pydantic import Field, ValidationError, model_validator

from kartci.core import Frozen
from kartci.errors import SpecError
from kartci.logs import LogReader, TopicInfo, topics
from kartci.logs.poses import POSE_TYPES
from kartci.metrics.alignment import Alignment
from kartci.project import Project
from kartci.realdata.tfchain import TF_TYPES
from kartci.scenario.models import Criterion
from kartci.scenario.yamlio import read_yaml

COMMAND_TYPES = ("ackermann_msgs/msg/AckermannDriveStamped", "geometry_msgs/msg/TwistStamped",
                 "geometry_msgs/msg/Twist", "sensor_msgs/msg/Joy",
                 "kartci_msgs/msg/KartCommand")
IMU_TYPES = ("sensor_msgs/msg/Imu",)
LIDAR_TYPES = ("sensor_msgs/msg/LaserScan", "sensor_msgs/msg/PointCloud2")
COLLISION_TYPES = ("kartci_msgs/msg/Collision",)


class TopicRole(Frozen):
    """One topic of the log and the frame its data is in (checked when given)."""

    topic: str = Field(description="the topic's name in the log")
    frame_id: str | None = Field(None, description="expected header frame_id; none: any")


class PoseRole(TopicRole):
    """A pose topic, or a TF chain: `topic: /tf` with the `parent` and `child` frames (any
    chain of /tf and /tf_static edges between them, sampled at the other pose's stamps)."""

    parent: str | None = Field(None, description="TF: the frame the pose is in (map)")
    child: str | None = Field(None, description="TF: the frame whose pose it is (base_link)")

    @model_validator(mode="after")
    def _both_frames(self) -> PoseRole:
        if (self.parent is None) != (self.child is None):
            raise ValueError("a TF pose names both `parent` and `child`")
        return self

    @property
    def is_tf(self) -> bool:
        """Whether this pose comes from TF (parent and child given) rather than a topic."""
        return self.parent is not None


class Mount(Frozen):
    """Where a sensor sits on the robot: its frame in the pose's child frame (base_link)."""

    x_m: float = Field(0.0, ge=-100.0, le=100.0, description="forward of the base, m")
    y_m: float = Field(0.0, ge=-100.0, le=100.0, description="left of the base, m")
    z_m: float = Field(0.0, ge=-100.0, le=100.0, description="above the base, m")
    yaw_rad: float = Field(0.0, ge=-7.0, le=7.0, description="turned left of the base's x, rad")


class LidarRole(TopicRole):
    """The lidar, and its mount when the log's /tf_static does not give it."""

    mount: Mount | None = Field(None, description="the lidar's frame in the base's, when the "
                                "log has no /tf_static chain from the pose's child frame to it")


class CommandRole(TopicRole):
    """The command stream and how the real robot turned it into actuation."""

    mapping: str = Field("ps4", description="joystick mapping, for sensor_msgs/Joy commands")
    wheel_radius_m: float = Field(0.035, gt=0.0, description="wheel radius the real robot's "
                                  "base controller converts Twist to wheel speeds with, m "
                                  "(differential drive)")
    wheel_separation_m: float = Field(0.15, gt=0.0, description="wheel separation the real "
                                      "robot's base controller uses, m (differential drive)")
    # the base controller's limits (ros2_controllers' diff_drive_controller has the same):
    # without them a fitted wheel radius absorbs a speed the real robot never reached
    max_speed_mps: float | None = Field(None, gt=0.0, le=100.0, description="largest |forward "
                                        "speed| the base controller commands, m/s; none: no "
                                        "limit (differential drive)")
    max_accel_mps2: float | None = Field(None, gt=0.0, le=1000.0, description="largest change "
                                         "of the commanded speed, m/s^2; none: no limit")
    max_yaw_rate_radps: float | None = Field(None, gt=0.0, le=100.0, description="largest "
                                             "|commanded yaw rate|, rad/s; none: no limit")
    max_yaw_accel_radps2: float | None = Field(None, gt=0.0, le=1000.0, description="largest "
                                               "change of the commanded yaw rate, rad/s^2; "
                                               "none: no limit")


class Profile(Frozen):
    """How a foreign log maps onto kartci's roles."""

    name: str = Field(pattern=r"^[a-z0-9_]+$", description="name of the scored result folder "
                      "and its baseline")
    description: str = Field("", description="one line about the log")
    agent: str = Field("robot", pattern=r"^[a-z0-9_]+$", description="the robot's namespace "
                       "in the imported run log")
    pose: PoseRole = Field(description="the reference pose: nav_msgs/Odometry, PoseStamped, "
                           "PoseWithCovarianceStamped, a planar turtlesim/Pose or Pose2D (x, "
                           "y, theta; log time, no frame), or a TF chain (topic /tf, parent, "
                           "child)")
    estimate: PoseRole | None = Field(None, description="a pose estimate judged against the "
                                      "reference (localization error); a topic or a TF chain")
    align: Alignment = Field(Alignment.NONE, description="the estimate moved onto the "
                             "reference before APE / RPE: none, se3, sim3 (Umeyama; evo -a, "
                             "-as) or origin (evo --align_origin); `kartci score --align`")
    align_first: int | None = Field(None, ge=2, description="se3 / sim3 fitted on the first "
                                    "N pose pairs (evo --n_to_align); none: all")
    t_max_diff_s: float | None = Field(None, gt=0.0, le=3600.0, description="the largest "
                                       "stamp difference of an estimate / reference pose "
                                       "pair, s (evo --t_max_diff); none: 0.01 s, evo's "
                                       "default; `kartci score --t-max-diff`")
    commands: CommandRole | None = Field(None, description="the command stream: Twist, "
                                         "TwistStamped, AckermannDriveStamped, Joy, KartCommand")
    imu: TopicRole | None = Field(None, description="sensor_msgs/Imu")
    lidar: LidarRole | None = Field(None, description="LaserScan or PointCloud2, and its mount")
    collisions: TopicRole | None = Field(None, description="recorded collisions "
                                         "(kartci_msgs/Collision): counted as `collisions`")
    robot: dict[str, Any] | None = Field(None, description="the robot for simreal/calibrate: "
                                         "{kind: NAME, ...params}; default: the scenario's")
    scenario: str | None = Field(None, description="scenario whose world and robot simreal "
                                 "uses (default: by robot kind)")
    track: str | None = Field(None, description="TUMFTM track CSV the log was driven on "
                              "(relative to the profile file): laps, lap times, cross-track")
    criteria: dict[str, Criterion] = Field({}, description="pass criteria on the scored "
                                           "metrics (simreal's divergence among them), as a "
                                           "scenario's: a failed one fails the log (exit 1)")

    def roles(self) -> dict[str, tuple[TopicRole, tuple[str, ...]]]:
        """Every topic the profile names, with the message types its role accepts."""
        out: dict[str, tuple[TopicRole, tuple[str, ...]]] = {"pose": (self.pose,
                                                                     _pose_types(self.pose))}
        for name, role, types in (("estimate", self.estimate, _pose_types(self.estimate)),
                                  ("commands", self.commands, COMMAND_TYPES),
                                  ("imu", self.imu, IMU_TYPES),
                                  ("lidar", self.lidar, LIDAR_TYPES),
                                  ("collisions", self.collisions, COLLISION_TYPES)):
            if role is not None:
                out[name] = (role, types)
        return out


def _pose_types(role: PoseRole | None) -> tuple[str, ...]:
    return TF_TYPES if role is not None and role.is_tf else POSE_TYPES


def load_profile(path: Path, proj: Project, allow_outside: bool = False) -> Profile:
    """A profile file, validated; a SpecError naming the file and the key otherwise. Its track
    must lie inside the project `proj` or kartci's data, as a scenario's does, unless
    `allow_outside`: the profile is the user's choice, the file it names may not be."""
    data = read_yaml(path)  # as scenario files are: a small regular file, no duplicate keys
    data.setdefault("name", re.sub(r"[^a-z0-9_]", "_", path.stem.lower()))
    try:
        profile = Profile.model_validate(data)
    except ValidationError as err:
        first = err.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "(top)"
        raise SpecError(f"{path}: {where}: {first['msg']}") from err
    if profile.track is not None:  # relative to the profile file
        track = proj.contained(path.parent / profile.track, f"{path}: track", allow_outside)
        profile = profile.model_copy(update={"track": str(track)})
    return profile


def auto_profile(log: Path, info: list[TopicInfo], sensors: bool = False) -> Profile:
    """A profile guessed from the log: its only pose/odometry topic, its only command topic
    (and with `sensors`, for a command that reads them: its only IMU and lidar topics)."""
    name = re.sub(r"[^a-z0-9_]", "_", log.name.split(".")[0].lower()) or "log"
    poses = [i for i in info if i.msgtype in POSE_TYPES and i.count > 0]
    if len(poses) != 1:
        listed = ", ".join(f"{i.topic} ({i.msgtype}, {i.count})" for i in info) or "none"
        what = "no pose or odometry topic" if not poses else "several pose topics"
        raise SpecError(f"{log}: {what} with messages (topics: {listed}); "
                        "name the pose in a profile (--profile)")
    cmds = [i for i in info if i.msgtype in COMMAND_TYPES and i.count > 0]
    imus = [i for i in info if sensors and i.msgtype in IMU_TYPES and i.count > 0]
    lidars = [i for i in info if sensors and i.msgtype in LIDAR_TYPES and i.count > 0]
    return Profile(name=name, pose=PoseRole(topic=poses[0].topic),
                   commands=CommandRole(topic=cmds[0].topic) if len(cmds) == 1 else None,
                   imu=TopicRole(topic=imus[0].topic) if len(imus) == 1 else None,
                   lidar=LidarRole(topic=lidars[0].topic) if len(lidars) == 1 else None)


def check_profile(log: Path, profile: Profile, known: list[TopicInfo] | None = None
                  ) -> dict[str, TopicInfo]:
    """The log's topic for every role of the profile; a SpecError naming the first role whose
    topic is missing, empty or of a type that role cannot use. `known`: the log's topics when
    the caller has read them (the log is not opened again)."""
    _check_distinct(log, profile)
    info = {i.topic: i for i in (topics(log) if known is None else known)}
    listed = ", ".join(f"{i.topic} ({i.msgtype}, {i.count})" for i in info.values()) or "none"
    out: dict[str, TopicInfo] = {}
    for name, (role, types) in profile.roles().items():
        found = info.get(role.topic)
        if found is None:
            raise SpecError(f"{log}: profile {profile.name}: {name} topic {role.topic} is not in "
                            f"the log (topics: {listed})")
        if found.msgtype not in types:
            tf = (" (a TF pose: `topic: /tf` with `parent` and `child` frames)"
                  if name in ("pose", "estimate") else "")
            raise SpecError(f"{log}: profile {profile.name}: {name} topic {role.topic} is "
                            f"{found.msgtype}; a {name} topic is one of {', '.join(types)}{tf}")
        if found.count == 0:
            raise SpecError(f"{log}: profile {profile.name}: {name} topic {role.topic} has no "
                            "messages")
        out[name] = found
    return out


def _check_distinct(log: Path, profile: Profile) -> None:
    """Two roles on one source: an estimate on the reference's own topic (or TF chain) would be
    judged against itself, and the importer keeps one role per topic (the other read as
    empty, which said "holds no readable pose" of a topic that scores fine alone)."""
    seen: dict[tuple[str, str | None, str | None], str] = {}
    for name, (role, _) in profile.roles().items():
        key = (role.topic, getattr(role, "parent", None), getattr(role, "child", None))
        first = seen.setdefault(key, name)
        if first == name:
            continue
        source = (f"TF chain {key[1]} -> {key[2]}" if key[1] is not None and key[2] is not None
                  else f"topic {role.topic}")
        why = ("an estimate judged against its own reference has no error to measure; name "
               "the estimate's own topic, or drop `estimate`" if {first, name} ==
               {"pose", "estimate"} else "each role needs a source of its own")
        raise SpecError(f"{log}: profile {profile.name}: {name} and {first} name the same "
                        f"{source}: {why}")


def resolve_profile(log: Path, path: Path | None, proj: Project, allow_outside: bool = False,
                    reader: LogReader | None = None, sensors: bool = False
                    ) -> tuple[Profile, dict[str, TopicInfo]]:
    """The profile (from its file, else guessed from the log, its sensors too with `sensors`)
    and the log's topic per role; the log's topics are read once (from `reader` when the
    caller has the log open)."""
    loaded = load_profile(path, proj, allow_outside) if path is not None else None
    known = reader.topics() if reader is not None else topics(log)
    profile = loaded if loaded is not None else auto_profile(log, known, sensors)
    return profile, check_profile(log, profile, known)
