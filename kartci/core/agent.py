"""What every agent is: something that reads messages and, at its own period, publishes some."""

from __future__ import annotations

from typing import Any, Protocol

Outbox = list[tuple[str, Any]]  # (topic relative to the agent's namespace, message)


class Agent(Protocol):
    """A controller or input source. Agents see the world only through messages: the same
    topics that are recorded, so a controller that runs in kartci would run on a robot.

    Implement it to drive a robot from your own code, register it as a controller (see
    `kartci.core.Controller`), or hand an object in directly:
    `kartci.run("kart_wall", agents={"kart0": MyController()})`.

    ```python
    import numpy as np
    from kartci.logs import header, msg

    class Bang:  # a line tracker's bang-bang controller
        period_s = 0.06  # a whole multiple of the scenario's physics.dt_s
        inputs = ("line_sensor",)
        left = right = 0.0

        def on_message(self, topic: str, message: Any) -> None:
            self.left, self.right = message.left, message.right

        def step(self, t_ns: int) -> list[tuple[str, Any]]:
            turn = 0.5 if self.left > self.right else -0.5  # towards the darker (line) side
            return [("wheel_cmd", msg("sensor_msgs/msg/JointState",
                                      header=header(t_ns, "base_link"), name=[],
                                      position=np.zeros(0), effort=np.zeros(0),
                                      velocity=np.array([3.0 + turn, 3.0 - turn])))]
    ```

    An agent that holds resources (a process, a socket) may also have a `close()`: it is
    called once when the run ends, however it ends.

    Attributes:
        period_s: Control period, s: `step` runs every `period_s`, which must be a whole
            multiple of the scenario's `physics.dt_s`.
        inputs: Topics the agent reads; relative names are in its robot's namespace
            (`"odom"` is `/<agent>/odom`), absolute ones (`"/tf"`) are taken as they are.
    """

    period_s: float
    inputs: tuple[str, ...]

    def on_message(self, topic: str, message: Any) -> None:
        """Take one message of a topic in `inputs`, named as `inputs` names it; called as it
        is published, before the next `step`."""
        ...

    def step(self, t_ns: int) -> Outbox:
        """Run one control tick at sim time `t_ns` (ns) and return the messages to publish,
        as (topic, message): relative topics go into the agent's namespace. The robot acts on
        the commands it understands (a line tracker's `wheel_cmd`, wheel speeds in rad/s; a
        kart's `cmd`); everything is recorded."""
        ...
