"""The contract between the stepping loop and a robot kind: the loop knows nothing else.

A robot kind's factory gets a `RobotContext` and returns something that fulfils `Robot`; the
world it lives in fulfils `SimWorld`. Topics a robot puts are relative to its namespace
(`odom` -> `/<name>/odom`) unless absolute.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from kartci.core import Agent, WorldParams
from kartci.scenario.models import AgentSpec, Pose2D


class Put(Protocol):
    """Publish one message: (topic, message, t ns). `record=False` hands it to the agents and
    nodes that read the topic without writing it to the log (every lidar scan feeds a
    localization, only every Nth is kept); unread, it is dropped."""

    def __call__(self, topic: str, message: Any, t_ns: int, record: bool = True) -> None:
        """Publish `message` on `topic` at sim time `t_ns`."""
        ...


class SimWorld(Protocol):
    """A PyBullet world: the client every body lives in, the floor, names of bodies for
    collision reports, and the robots in it (so sensors can see each other)."""

    @property
    def spec(self) -> WorldParams:
        """The world's parameters from the scenario."""
        ...

    @property
    def client(self) -> int:
        """The PyBullet physics client every body lives in."""
        ...

    @property
    def floor(self) -> int:
        """Body id of the floor (contacts with it are not collisions)."""
        ...

    @property
    def names(self) -> dict[int, str]:
        """Body id -> name, for collision reports."""
        ...

    @property
    def robots(self) -> list[Robot]:
        """Every robot in the world, so sensors can see each other."""
        ...

    def start_pose(self, start: Pose2D) -> tuple[float, float, float]:
        """x, y (m) and yaw (rad) of a start given along the world's course or track."""
        ...

    def static_messages(self) -> list[tuple[str, Any]]:
        """Messages at t = 0 that describe the world (course, track, obstacles)."""
        ...

    def step(self) -> None:
        """Advance the physics by one step."""
        ...

    def close(self) -> None:
        """Disconnect the physics client."""
        ...


@dataclass(frozen=True)
class RobotContext:
    """What a robot kind's factory is given."""

    name: str
    spec: AgentSpec
    world: SimWorld
    agent: Agent
    dt_s: float
    odom_every: int  # physics steps per odometry message
    rng: np.random.Generator  # the run's one seeded generator


class Robot(Protocol):
    """A body, its sensors and its agent, publishing under one namespace."""

    name: str
    agent: Agent
    ctrl_every: int  # physics steps per control tick

    def static_transforms(self) -> list[Any]:
        """tf of the fixed frames (sensor mounts), published once on /tf_static."""
        ...

    def sense(self, k: int, t_ns: int, put: Put) -> None:
        """Publish what the robot senses at physics step k."""
        ...

    def apply(self, topic: str, message: Any) -> None:
        """Take a message its agent published (commands it understands, others ignored)."""
        ...

    def pre_step(self, k: int) -> None:
        """Actuators, before the physics step."""
        ...

    def post_step(self, t_ns: int, put: Put) -> None:
        """After the physics step (contacts, events)."""
        ...

    def finish(self, put: Put) -> None:
        """At the end of the run (events still open)."""
        ...

    def done(self, k: int) -> bool:
        """True when this robot's run is over (a line tracker past the course's end)."""
        ...
