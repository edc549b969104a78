"""Import a foreign log as a kartci run log: the profile's topics under the robot's namespace
(`/<agent>/odom`, `/<agent>/estimate`, `/<agent>/cmd_vel`, ...), the track, and a recorded
scenario saying what was imported. From there the same code scores, judges and reports it as a
simulated run, and `kartci report OUT` re-scores it from that log alone."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from kartci import core
from kartci.errors import LogError
from kartci.logs import SCENARIO_TOPIC, LogReader, McapLogWriter, msg, open_log, stamp_ns
from kartci.logs.poses import (
    ODOMETRY,
    Poses,
    body_twist,
    decode_poses,
    odometry_cdr,
    same_definitions,
)
from kartci.logs.reader import Raw
from kartci.logs.tables import odometry_table, remember, tables_of
from kartci.logs.types import for_writing, typestore
from kartci.metrics.alignment import Alignment
from kartci.realdata.profile import PoseRole, Profile
from kartci.realdata.tfchain import TF_TYPES, TfTree
from kartci.scenario import Scenario
from kartci.scenario.dispatch import context
from kartci.scenario.yamlio import TRACK_MAX_BYTES, read_text_bounded
from kartci.worlds.track import TRACK_TOPIC

# where each role's messages go, relative to the robot's namespace (commands by type)
COMMAND_TOPIC = {"ackermann_msgs/msg/AckermannDriveStamped": "ackermann_cmd",
                 "geometry_msgs/msg/TwistStamped": "cmd_vel", "geometry_msgs/msg/Twist": "cmd_vel",
                 "sensor_msgs/msg/Joy": "joy", "kartci_msgs/msg/KartCommand": "cmd"}
ROLE_TOPIC = {"pose": "odom", "estimate": "estimate", "imu": "imu"}
LIDAR_TOPIC = {"sensor_msgs/msg/LaserScan": "scan",
               "sensor_msgs/msg/PointCloud2": "velodyne_points"}
MAX_DURATION_S = 3600.0  # a scenario's limit; longer logs are recorded as this long


def imported_scenario(profile: Profile, duration_s: float, start: str = "") -> Scenario:
    """The scenario an imported log records: world and robot `recorded`, the profile's track,
    the motion metrics and, with an estimate, the localization metrics; `start`: what time 0 s
    of the imported log is (said once, in the description)."""
    metrics: dict[str, Any] = {"motion": {}}
    if profile.estimate is not None:
        metrics["localization"] = {"topic": ROLE_TOPIC["estimate"], "align": profile.align,
                                   "align_first": profile.align_first}
        if profile.t_max_diff_s is not None:  # unset: the metric's default, as evo's
            metrics["localization"]["max_diff_s"] = profile.t_max_diff_s
    world: dict[str, Any] = {"kind": "recorded", "description": profile.description}
    if profile.track is not None:
        world["track"] = profile.track
    return Scenario.model_validate({
        "name": profile.name, "description": (profile.description or f"imported log "
                                              f"({profile.name})") + start, "world": world,
        "agents": {profile.agent: {"model": {"kind": "recorded"},
                                   "controller": {"type": "recorded"}}},
        "duration_s": min(max(duration_s, 1e-3), MAX_DURATION_S), "metrics": metrics,
        "criteria": {k: c.model_dump() for k, c in profile.criteria.items()}},
        context=context(core.DEFAULT_REGISTRIES))


@dataclass(frozen=True)
class ImportedOdometry:
    """A pose stream as the imported log's nav_msgs/Odometry: stamps (ns since the log's
    start), position, quaternion and body twist (the message's own for Odometry, else from
    finite differences of the poses)."""

    t_log: np.ndarray  # ns
    stamp: np.ndarray  # ns
    xyz: np.ndarray
    quat: np.ndarray
    twist: np.ndarray

    def messages(self, frame: str) -> list[bytes]:
        """The messages, CDR-encoded (header frame `frame`, child base_link)."""
        return odometry_cdr(self.stamp, frame, "base_link", self.xyz, self.quat, self.twist)

    def table(self) -> Any:
        """The messages' table, as kartci.logs.tables makes it."""
        return odometry_table(self.stamp, self.xyz, self.quat, self.twist)


def odometry_of(poses: Poses, start_ns: int = 0) -> ImportedOdometry:
    """`poses` as the imported log's odometry, stamps and log times `start_ns` earlier."""
    ts = poses.times() - start_ns
    twist = poses.twist if poses.twist is not None else body_twist(ts, poses.xyz, poses.quat)
    return ImportedOdometry(poses.t_log - start_ns, ts, poses.xyz, poses.quat, twist)


_ZEROS36 = np.zeros(36)  # every imported covariance (read-only: shared by the messages)


def _odom(t_ns: int, frame: str, xyz: tuple[float, float, float],
          q: tuple[float, float, float, float], v: tuple[float, ...]) -> Any:
    """A nav_msgs/Odometry (the classes taken once: a long log builds tens of thousands)."""
    t = typestore().types
    vec = t["geometry_msgs/msg/Vector3"]
    sec, nsec = divmod(t_ns, 1_000_000_000)
    pose = t["geometry_msgs/msg/Pose"](
        position=t["geometry_msgs/msg/Point"](x=float(xyz[0]), y=float(xyz[1]),
                                              z=float(xyz[2])),
        orientation=t["geometry_msgs/msg/Quaternion"](x=float(q[0]), y=float(q[1]),
                                                      z=float(q[2]), w=float(q[3])))
    twist = t["geometry_msgs/msg/Twist"](linear=vec(x=float(v[0]), y=float(v[1]),
                                                    z=float(v[2])),
                                         angular=vec(x=float(v[3]), y=float(v[4]),
                                                     z=float(v[5])))
    return t["nav_msgs/msg/Odometry"](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](
            sec=sec, nanosec=nsec), frame_id=frame), child_frame_id="base_link",
        pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=_ZEROS36),
        twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=_ZEROS36))


def _destinations(profile: Profile, types: dict[str, str]) -> dict[str, str]:
    """Log topic -> topic in the imported log, for every role but pose and estimate."""
    out: dict[str, str] = {}
    ns = profile.agent
    if profile.commands is not None:
        out[profile.commands.topic] = f"/{ns}/{COMMAND_TOPIC[types['commands']]}"
    if profile.imu is not None:
        out[profile.imu.topic] = f"/{ns}/imu"
    if profile.lidar is not None:
        out[profile.lidar.topic] = f"/{ns}/{LIDAR_TOPIC[types['lidar']]}"
    if profile.collisions is not None:
        out[profile.collisions.topic] = f"/{ns}/collision"
    return out


@dataclass(frozen=True)
class Imported:
    """What an import wrote: the recorded scenario, and what a reader should be told."""

    scenario: Scenario
    warnings: tuple[str, ...]


@dataclass
class _Collected:
    """What the import read from the log: each pose role's stream, the copied messages
    (destination topic, log time, message), each pose role's frame."""

    poses: dict[str, Poses]
    other: list[tuple[str, int, Any]]
    frames: dict[str, str]


def _pose_roles(profile: Profile) -> dict[str, PoseRole]:
    return {"pose": profile.pose,
            **({"estimate": profile.estimate} if profile.estimate is not None else {})}


_NO_POSES = decode_poses([], standard=True, decode=lambda raw: None)


def _collect(log: Path, reader: LogReader, profile: Profile, types: dict[str, str]
             ) -> _Collected:
    copy = _destinations(profile, types)
    roles = _pose_roles(profile)
    by_topic = {r.topic: name for name, r in roles.items() if not r.is_tf}
    tf_topics = {r.topic for r in roles.values() if r.is_tf}
    if tf_topics:  # the static edges of the chain, wherever the log has them
        tf_topics |= {i.topic for i in reader.topics()
                      if i.topic.endswith("tf_static") and i.msgtype in TF_TYPES}
    checks = {role.topic: role.frame_id for role, _ in profile.roles().values()
              if role.frame_id is not None}
    got = _Collected({name: _NO_POSES for name in roles}, [], {})
    raws: dict[str, list[Raw]] = {name: [] for name in by_topic.values()}
    tree = TfTree()
    for raw in reader.raw([*by_topic, *tf_topics, *copy]):
        topic = raw[0]
        if topic in by_topic:  # decoded in bulk below
            raws[by_topic[topic]].append(raw)
            continue
        m = reader.decode(raw)
        if m is None:
            continue
        _check_frame(log, checks, topic, getattr(getattr(m, "header", None), "frame_id", None))
        if topic in tf_topics:
            tree.add(m, static=topic.endswith("tf_static"))
        else:
            got.other.append((copy[topic], raw[3], m))
    _decode_roles(log, reader, by_topic, raws, types, checks, got)
    for name, role in roles.items():
        if role.is_tf:
            others = [p for other, p in got.poses.items() if other != name and len(p)]
            got.poses[name] = _tf_poses(log, tree, role, others[0] if others else None)
            got.frames[name] = _frame_name(role.parent)
    return got


def _decode_roles(log: Path, reader: LogReader, by_topic: dict[str, str],
                  raws: dict[str, list[Raw]], types: dict[str, str], checks: dict[str, str],
                  got: _Collected) -> None:
    """Each pose role's messages decoded in bulk (kartci.logs.poses) into `got`."""
    for topic, name in by_topic.items():
        poses = decode_poses(raws[name], same_definitions(reader.typestore, types[name]),
                             reader.decode)
        for frame in poses.frames:
            _check_frame(log, checks, topic, frame)
        got.poses[name] = poses
        if poses.frames:  # planar poses have no header, hence no frame
            got.frames[name] = poses.frames[0].lstrip("/")
    reader.report_undecodable()


def _frame_name(name: str | None) -> str:
    return (name or "").lstrip("/")


def _tf_poses(log: Path, tree: TfTree, role: PoseRole, at: Poses | None) -> Poses:
    """The TF chain's poses, at the other trajectory's stamps (`at`), else at the chain's
    own."""
    parent, child = role.parent or "", role.child or ""
    try:
        stamps = at.times() if at is not None else tree.stamps(parent, child)
        t_ns, xyz, quat = tree.lookup(parent, child, stamps)
    except LogError as err:
        raise LogError(f"{log}: {err}") from err
    if len(t_ns) == 0:
        raise LogError(f"{log}: the TF chain from '{parent}' to '{child}' covers none of the "
                       "other pose's stamps")
    t_ns = np.asarray(t_ns, np.int64)
    return Poses(t_ns, t_ns, np.asarray(xyz, float), np.asarray(quat, float), None, (parent,))


def import_log(log: Path, profile: Profile, types: dict[str, str], dst: Path,
               reader: LogReader | None = None) -> Imported:
    """Write `dst` (a kartci run log) from `log` as the profile maps it; returns its scenario
    and warnings. `types`: the message type of each role's topic (from `check_profile`);
    `reader`: `log` already open (a damaged log is then not salvaged twice)."""
    if reader is None:
        with open_log(log) as opened:
            return import_log(log, profile, types, dst, opened)
    ns = profile.agent
    store = for_writing(reader.typestore)
    got = _collect(log, reader, profile, types)
    poses = got.poses
    if not len(poses["pose"]):
        raise LogError(f"{log}: {profile.pose.topic} holds no readable pose")
    start = _start_ns(got)  # one time base: seconds since the log's start
    t0 = int(poses["pose"].t_log.min()) - start
    t1 = int(poses["pose"].t_log.max()) - start
    scenario = imported_scenario(profile, (t1 - t0) * 1e-9, _said(start))
    out: list[tuple[str, int, Any]] = [
        (SCENARIO_TOPIC, t0, msg("std_msgs/msg/String", data=scenario.model_dump_json()))]
    if profile.track is not None:
        out.append((TRACK_TOPIC, t0, msg("std_msgs/msg/String", data=_read(profile.track))))
    odometry: dict[str, ImportedOdometry] = {}
    for role, name in (("pose", "odom"), ("estimate", "estimate")):
        if role in poses and len(poses[role]):
            topic = f"/{ns}/{name}"
            odometry[topic] = odom = odometry_of(poses[role], start)
            out += zip([topic] * len(odom.t_log), odom.t_log.tolist(), odom.messages("map"),
                       strict=True)
    out += [(topic, t - start, _shifted(m, start)) for topic, t, m in got.other]
    out.sort(key=lambda item: item[1])
    with McapLogWriter(dst, store) as writer:
        for topic, t_ns, m in out:
            if isinstance(m, bytes):
                writer.write_cdr(topic, ODOMETRY, m, t_ns)
            else:
                writer.write(topic, m, t_ns)
    read = tables_of(dst, ((topic, t, m) for topic, t, m in out if not isinstance(m, bytes)))
    remember(dst, {**read, **{topic: odom.table() for topic, odom in odometry.items()}})
    return Imported(scenario, frame_warnings(profile, got.frames))


def _header_ns(m: Any) -> int:
    hdr = getattr(m, "header", None)
    return stamp_ns(hdr) if hdr is not None else 0


def _start_ns(got: _Collected) -> int:
    """The imported log's start: its earliest log time or header stamp (unset stamps, 0,
    aside)."""
    times = [int(t.min()) for p in got.poses.values() if len(p) for t in (p.t_log, p.times())]
    times += [t for _, t, _ in got.other]
    times += [s for s in (_header_ns(m) for _, _, m in got.other) if s > 0]
    return min(times)


def _said(start_ns: int) -> str:
    """Time 0 s of an imported log, in words: a date for wall-clock stamps, else the stamp
    (a simulator's clock)."""
    if start_ns >= 10**18:  # after 2001-09-09: a wall clock
        when = datetime.fromtimestamp(start_ns // 10**9, UTC).strftime("%Y-%m-%dT%H:%M:%S")
        return f"; t = 0 s is {when}.{start_ns % 10**9 // 10**6:03d}Z"
    return f"; t = 0 s is stamp {start_ns * 1e-9:.3f} s"


def _shifted(m: Any, start_ns: int) -> Any:
    """A copied message with its header stamp `start_ns` earlier (unset stamps stay 0)."""
    t = _header_ns(m)
    if t > 0:
        sec, nsec = divmod(max(t - start_ns, 0), 1_000_000_000)
        m.header.stamp = typestore().types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)
    return m


def frame_warnings(profile: Profile, frames: dict[str, str]) -> tuple[str, ...]:
    """A reference and an estimate in different frames compared without alignment: the APE
    then measures the offset between the frames (odometry against AMCL's map: metres), not
    the estimate. Told, with the fix; not refused (the frames may coincide by construction)."""
    ref, est = frames.get("pose"), frames.get("estimate")
    if profile.estimate is None or not ref or not est or ref == est:
        return ()
    if profile.align is not Alignment.NONE:
        return ()
    return (f"the reference {profile.pose.topic} is in frame '{ref}' and the estimate "
            f"{profile.estimate.topic} in '{est}', compared without alignment: APE includes "
            "the offset between the frames; align them with --align se3 (sim3 for an estimate "
            "without scale, origin for the start pose) or `align:` in the profile",)


def _check_frame(log: Path, frames: dict[str, str], topic: str, got: str | None) -> None:
    """A message's header frame (`got`; None without a header) must be the one its role
    names (when it names one)."""
    want = frames.get(topic)
    if want is not None and got is not None and got.lstrip("/") != want.lstrip("/"):
        raise LogError(f"{log}: {topic} is in frame '{got}', the profile expects '{want}'")


def _read(path: str) -> str:
    """The profile's track file: a small regular text file (yamlio's bounds), or a SpecError."""
    return read_text_bounded(Path(path), TRACK_MAX_BYTES)
