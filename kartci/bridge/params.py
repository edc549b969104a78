"""Parameters of `controller: {type: external}`: a team's own stack, closed loop over Zenoh."""

from __future__ import annotations

from enum import Enum
from typing import Literal

from pydantic import Field, field_validator

from kartci.bridge.lockstep import Phase
from kartci.bridge.ros2 import DEFAULT_DISTRO, Distro
from kartci.core import ROBOTS, ControllerParams, Frozen, Registry, RobotKind
from kartci.core.params import Count, Period_s

COMMAND_TYPES = {  # what the bridge takes back, and the robot topic each is applied on
    "ackermann_msgs/msg/AckermannDriveStamped": "ackermann_cmd",
    "geometry_msgs/msg/Twist": "cmd_vel",
    "geometry_msgs/msg/TwistStamped": "cmd_vel",
    "sensor_msgs/msg/Joy": "joy",
}


def command_types(robots: Registry[RobotKind] = ROBOTS) -> dict[str, str]:
    """Every command type the bridge takes back, and the robot topic it is applied on: the
    standard ones above and each registered kind's own (`RobotKind.commands`)."""
    out = dict(COMMAND_TYPES)
    for kind in robots.all():
        for msgtype, topic in kind.commands.items():
            out.setdefault(msgtype, topic)
    return out


class Mode(Enum):
    """How sim time and the stack meet."""

    LOCKSTEP = "lockstep"  # every control tick waits for the stack's answer: deterministic
    PACED = "paced"  # sim time runs at a real-time factor; the latest command is used


class CommandTopic(Frozen):
    """One command topic the stack publishes and the bridge applies to the robot."""

    topic: str = Field(description="topic the stack publishes on; relative names are in the "
                       "agent's namespace (`ackermann_cmd` is `/<agent>/ackermann_cmd`)")
    type: str = Field(description="its message type: a standard command "
                      f"({', '.join(COMMAND_TYPES)}) or one a robot kind declares")

    @field_validator("type")
    @classmethod
    def _known(cls, value: str) -> str:
        if value in COMMAND_TYPES:  # standard: no need to load every kind to know it
            return value
        known = command_types()
        if value not in known:
            raise ValueError(f"'{value}' is no command type the bridge takes back; expected "
                             f"one of {', '.join(sorted(known))}")
        return value


class WaitFor(Frozen):
    """A topic of the stack that each lockstep tick waits for (docs/explain/lockstep.md)."""

    topic: str = Field(description="topic a node of the stack publishes; relative names are in "
                       "the agent's namespace")
    count: int = Field(1, ge=0, le=1000, description="messages per tick it is due (0: never "
                       "wait for it)")
    every: int = Field(1, ge=1, le=1_000_000, description="it is due every this many ticks "
                       "(a node slower than the control period)")
    after: Phase | None = Field(None, description="what it answers: `sensors` (awaited before "
                                "/clock is published) or `clock` (after); default learnt at "
                                "tick 0")


class ExternalController(ControllerParams):
    """A separate program (a ROS 2 stack on rmw_zenoh, or anything speaking its conventions)
    that reads the robot's sensors and `/clock` and answers with commands."""

    type: Literal["external"] = Field("external", description="controller type: an external "
                                      "stack over Zenoh (rmw_zenoh conventions)")
    period_s: Period_s = Field(0.02, description="control period, s: /clock is published "
                               "and a command awaited every period (a whole multiple of "
                               "physics.dt_s)")
    publish: tuple[str, ...] = Field(("odom", "/kartci/track"), description="topics sent to "
                                     "the stack (besides /clock), as the robot publishes them: "
                                     "odom, imu, joint_states, velodyne_points, /tf, ...")
    commands: tuple[CommandTopic, ...] = Field(
        (CommandTopic(topic="ackermann_cmd", type="ackermann_msgs/msg/AckermannDriveStamped"),),
        min_length=1, description="topics the stack answers on")
    mapping: str = Field("ps4", description="joystick mapping for sensor_msgs/Joy commands")
    domain_id: int = Field(0, ge=0, le=232, description="ROS_DOMAIN_ID used in key "
                           "expressions (isolation comes from the run's private link)")
    node_name: str = Field("kartci", description="the bridge's ROS 2 node name")
    mode: Mode = Field(Mode.LOCKSTEP, description="lockstep (wait for every tick's answer, "
                       "deterministic) or paced (run at real_time_factor, not deterministic)")
    real_time_factor: float = Field(1.0, gt=0.0, le=1e6, description="paced mode: sim s per wall s")
    tick_timeout_s: Period_s = Field(1.0, description="lockstep: wall-clock deadline for "
                                     "one tick's answer; a miss is a late_commands event")
    max_late_in_row: Count = Field(5, description="this many late ticks in a row end the "
                                   "run as an error")
    startup_timeout_s: Period_s = Field(20.0, description="wall-clock time the stack has "
                                        "to declare its subscription to /clock and its command "
                                        "publishers")
    port: int | None = Field(None, ge=1, le=65535, description="loopback TCP port the "
                             "bridge listens on (tcp/127.0.0.1:<port>); default a free one per "
                             "run. Fix it for a stack you start yourself (no `command`)")
    # the three network-joining settings are left out of a dump (and so of a baseline's
    # scenario fields) at their defaults: they change what else shares the graph, not the run,
    # and baselines accepted before they existed stay current
    connect: tuple[str, ...] = Field(
        (), exclude_if=lambda v: v == (),
        description="Zenoh endpoints the bridge also connects to, e.g. a running router "
        "(`tcp/127.0.0.1:7447`, rmw_zenohd's default) so the team's other tools share the "
        "graph; it must be there when the run starts")
    zenoh_mode: Literal["peer", "router"] = Field(
        "peer", exclude_if=lambda v: v == "peer",
        description="the bridge's Zenoh mode: router lets rmw_zenoh nodes with their default "
        "config (a router on tcp/localhost:7447) use kartci as theirs (with port: 7447)")
    allow_remote: bool = Field(
        False, exclude_if=lambda v: v is False,
        description="allow endpoints beyond this host (in `connect` or "
        "$ZENOH_CONFIG_OVERRIDE) and multicast scouting; off, they are an error")
    # left out of a dump at its default too: baselines accepted before it existed stay current
    ros_distro: Distro = Field(
        DEFAULT_DISTRO, exclude_if=lambda v: v is DEFAULT_DISTRO,
        description="the stack's ROS 2 distribution: its message definitions (Range has "
        "`variance` from Jazzy on) and type hashes in keys and tokens (humble: "
        "TypeHashNotSupported, as rmw_zenoh on Humble writes); rolling uses Lyrical's definitions")
    middleware: Literal["zenoh", "dds"] = Field(
        "zenoh", exclude_if=lambda v: v == "zenoh",
        description="how the stack is reached: zenoh (rmw_zenoh's conventions, kartci's own "
        "session) or dds (Fast DDS through rclpy in a relay process under a ROS 2 Python: "
        "`kartci ros2 env` or $KARTCI_ROS2_PYTHON; shared memory only, a domain id per run "
        "when kartci starts the stack)")
    # left out of a dump at their defaults: baselines accepted before they existed stay current
    waits_for: tuple[WaitFor, ...] = Field(
        (), exclude_if=lambda v: v == (),
        description="lockstep: topics of the stack to wait for at each tick, with their "
        "counts and phases, beyond or instead of those the graph shows (every topic the "
        "stack publishes and subscribes to, once a tick, and every command topic)")
    graph_settle_s: float = Field(
        0.3, ge=0.0, le=60.0, exclude_if=lambda v: v == 0.3,
        description="lockstep: wall-clock time, s, the stack's graph must stay unchanged "
        "before t = 0 (its nodes' links to each other are not visible to kartci)")
    fence_s: float = Field(
        0.0, ge=0.0, le=1.0, exclude_if=lambda v: v == 0.0,
        description="lockstep: wall-clock pause, s, between the stack's answers to a tick's "
        "sensors and the tick's /clock, for links kartci does not route (DDS, Zenoh peers "
        "meshed with each other): there it sees a message between two nodes when it has it, "
        "not when the receiving node has (docs/explain/lockstep.md)")
    command: tuple[str, ...] = Field((), description="program kartci starts for the run "
                                     "(empty: start the stack yourself, connecting to "
                                     "`port`); `{python}` is kartci's Python, "
                                     "`{ros_python}` the ROS 2 Python (dds), "
                                     "`{endpoint}` the bridge's Zenoh endpoint, `{root}` the "
                                     "project folder, `{domain_id}` the domain")
    cwd: str | None = Field(None, description="its working directory, relative to the project "
                            "folder (default: the project folder)")
    env: dict[str, str] = Field(default_factory=dict, description="extra environment "
                                "variables for it")
    stop_timeout_s: Period_s = Field(3.0, description="time it has to exit after SIGTERM "
                                     "before it is killed")
