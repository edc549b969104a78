"""Agents: controllers and input sources. They read and publish messages, never sim state."""

from kartci.agents.base import Agent, Outbox
from kartci.agents.line_pid import LinePid
from kartci.spec.models import AgentSpec


def make_agent(spec: AgentSpec) -> Agent:
    """The controller an agent spec names (a registry of one type for now)."""
    return LinePid(spec.controller, spec.model)


__all__ = ["Agent", "LinePid", "Outbox", "make_agent"]
