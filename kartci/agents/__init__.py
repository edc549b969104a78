"""Agents: controllers and input sources. They read and publish messages, never sim state."""

from __future__ import annotations

from kartci.agents.base import Agent, Outbox
from kartci.agents.kart import CommandsAgent, JoyDriver, ManualAgent, ScriptAgent
from kartci.agents.line_pid import LinePid
from kartci.agents.mpcc import MpccAgent
from kartci.errors import SpecError
from kartci.spec.models import (
    AgentSpec,
    Box,
    CommandsController,
    GokartModel,
    JoyDriverController,
    LinePidController,
    LineTrackerModel,
    ManualController,
    MpccController,
    ScriptController,
)
from kartci.track import Track


def make_agent(spec: AgentSpec, track: Track | None = None, obstacles: tuple[Box, ...] = (),
               other_karts: tuple[str, ...] = ()) -> Agent:
    """The controller an agent spec names, checked against the robot it drives. `obstacles`
    and `other_karts` (agent names) are ground truth an MPCC may see."""
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
    if track is None:
        raise SpecError(f"controller {c.type} needs a world with a track")
    if isinstance(c, MpccController):
        return MpccAgent(c, m, track, obstacles, other_karts)
    assert isinstance(c, JoyDriverController)
    return JoyDriver(c, m, track)


__all__ = ["Agent", "LinePid", "Outbox", "make_agent"]
