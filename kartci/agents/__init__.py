"""Agents: controllers and input sources. They read and publish messages, never sim state."""

from __future__ import annotations

from kartci.agents.base import Agent, Outbox
from kartci.agents.kart import CommandsAgent, JoyDriver, ManualAgent, ScriptAgent
from kartci.agents.line_pid import LinePid
from kartci.errors import SpecError
from kartci.spec.models import (
    AgentSpec,
    CommandsController,
    GokartModel,
    JoyDriverController,
    LinePidController,
    LineTrackerModel,
    ManualController,
    ScriptController,
)
from kartci.track import Track


def make_agent(spec: AgentSpec, track: Track | None = None) -> Agent:
    """The controller an agent spec names, checked against the robot it drives."""
    c, m = spec.controller, spec.model
    if isinstance(c, LinePidController):
        if not isinstance(m, LineTrackerModel):
            raise SpecError("controller line_pid drives a line_tracker model only")
        return LinePid(c, m)
    if not isinstance(m, GokartModel):
        raise SpecError(f"controller {c.type} drives a gokart model only")
    if isinstance(c, ManualController):
        return ManualAgent(c, m)
    if isinstance(c, CommandsController):
        return CommandsAgent(c, m)
    if isinstance(c, ScriptController):
        return ScriptAgent(c)
    assert isinstance(c, JoyDriverController)
    if track is None:
        raise SpecError("controller joy_driver needs a world with a track")
    return JoyDriver(c, m, track)


__all__ = ["Agent", "LinePid", "Outbox", "make_agent"]
