"""What every agent is: something that reads messages and, at its own period, publishes some."""

from __future__ import annotations

from typing import Any, Protocol

Outbox = list[tuple[str, Any]]  # (topic relative to the agent's namespace, message)


class Agent(Protocol):
    """Agents see the world only through messages: the same topics that are recorded."""

    period_s: float
    inputs: tuple[str, ...]  # topics (relative to the namespace) the agent reads

    def on_message(self, topic: str, message: Any) -> None: ...

    def step(self, t_ns: int) -> Outbox: ...
