"""Input streams recorded in a log, re-based onto sim time: what replaying controllers drive a
robot from (a joystick's Joy messages, or drive commands)."""

from __future__ import annotations

import bisect
from pathlib import Path
from typing import Any

from kartci.errors import LogError
from kartci.logs import TopicInfo, open_log
from kartci.scenario.models import LogSource

JOY = ("sensor_msgs/msg/Joy",)
COMMANDS = ("ackermann_msgs/msg/AckermannDriveStamped", "geometry_msgs/msg/TwistStamped",
            "geometry_msgs/msg/Twist")


def resolve(path: str) -> Path:
    """Log paths are made absolute when the scenario is loaded; a relative one left over (a
    scenario built in Python) is relative to the working directory."""
    return Path(path).resolve()


class Recorded:
    """The messages of one topic; `at(t_ns)` is the latest one at or before sim time t."""

    def __init__(self, source: LogSource, types: tuple[str, ...]) -> None:
        path = resolve(source.log)
        with open_log(path) as log:  # opened once: its topics, then the stream's messages
            self.topic, self.msgtype = _pick(path, log.topics(), source, types)
            stream = [(t, m) for _, t, m in log.messages([self.topic])]
        if not stream:
            raise LogError(f"{path}: topic {self.topic} has no messages")
        t0 = stream[0][0]
        offset = round(source.time_offset_s * 1e9)
        self.times = [t - t0 + offset for t, _ in stream]
        self.msgs = [m for _, m in stream]
        self.path = path

    @property
    def duration_s(self) -> float:
        """Time from the first recorded message to the last, s."""
        return (self.times[-1] - self.times[0]) * 1e-9

    def at(self, t_ns: int) -> Any | None:
        """The latest message at or before sim time `t_ns`, or None before the first."""
        i = self.index(t_ns)
        return self.msgs[i] if i >= 0 else None

    def index(self, t_ns: int) -> int:
        """Index of the latest message at or before sim time t (-1: none yet)."""
        return bisect.bisect_right(self.times, t_ns) - 1


def _pick(path: Path, info: list[TopicInfo], source: LogSource, types: tuple[str, ...],
          ) -> tuple[str, str]:
    """The topic and type of the stream: the source's topic, or the one topic of `types`."""
    if source.topic is not None:
        match = [i for i in info if i.topic == source.topic]
        if not match:
            known = ", ".join(f"{i.topic} ({i.msgtype})" for i in info) or "none"
            raise LogError(f"{path}: no topic {source.topic} (topics: {known})")
        if match[0].msgtype not in types:
            raise LogError(f"{path}: {source.topic} is {match[0].msgtype}; expected one of "
                           f"{', '.join(types)}")
    else:
        match = [i for i in info if i.msgtype in types and i.count > 0]
        if len(match) != 1:
            found = "none" if not match else ", ".join(i.topic for i in match)
            raise LogError(f"{path}: needs exactly one topic of type {' or '.join(types)} "
                           f"with messages (found: {found}); name one with a topic option")
    return match[0].topic, match[0].msgtype
