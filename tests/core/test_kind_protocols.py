"""The kinds' functions are typed (issue 41): every function a built-in hands kartci through
`lazy("module:attr")` is assigned here to the `Protocol` of its field, so strict mypy checks it
against the signature kartci calls it with, as it checks a plugin that passes its functions."""

from __future__ import annotations

from kartci import core
from kartci.agents.builtin import EXTERNAL, LOCALIZATION, OBSTACLE_DETECTOR
from kartci.bridge.middleware import external_agent
from kartci.localization.node import LocalizationNode
from kartci.perception.node import ObstacleDetector
from kartci.realdata.plots import recorded_plots
from kartci.robots import gokart, line_tracker
from kartci.robots.gokart.control import control as kart_control
from kartci.robots.gokart.drivers import CommandsAgent, JoyDriver, ManualAgent, ScriptAgent, replay
from kartci.robots.gokart.joy import joystick
from kartci.robots.gokart.mpcc.agent import MpccAgent
from kartci.robots.gokart.mpcc.fit import fit_log
from kartci.robots.gokart.outline import outline
from kartci.robots.gokart.plots import kart_figures, kart_plots
from kartci.robots.gokart.robot import KartRobot
from kartci.robots.line_tracker.control import control as line_control
from kartci.robots.line_tracker.line_pid import LinePid
from kartci.robots.line_tracker.plots import line_figures, line_plots
from kartci.robots.line_tracker.robot import LineTrackerRobot
from kartci.worlds.circuit.world import Circuit
from kartci.worlds.hall.world import Hall
from kartci.worlds.line_lab.world import LineLab

ROBOTS: list[core.RobotFactory] = [KartRobot, LineTrackerRobot]
PLOTS: list[core.PlotsFn] = [kart_plots, line_plots, recorded_plots]
FIGURES: list[core.FiguresFn] = [kart_figures, line_figures]
OUTLINES: list[core.OutlineFn] = [outline]
JOYSTICKS: list[core.JoystickFn] = [joystick]
REPLAYS: list[core.ReplayFn] = [replay]
CONTROLS: list[core.ControlFn] = [kart_control, line_control]
WORLDS: list[core.WorldFactory] = [Hall, Circuit, LineLab]
AGENTS: list[core.AgentFactory] = [external_agent, LocalizationNode, ObstacleDetector, LinePid,
                                   ManualAgent, CommandsAgent, ScriptAgent, JoyDriver, MpccAgent]
FITS: list[core.FitModel] = [fit_log]


def _target(f: object) -> str:
    """`module:attr` of a function or class (a `lazy` one's name is its target)."""
    return f"{getattr(f, '__module__', '')}:{getattr(f, '__qualname__', '')}"


def test_every_lazy_target_of_a_built_in_is_one_typed_here() -> None:
    """The typed lists above hold what the built-ins' registrations name, so none is left
    unchecked."""
    typed: set[str] = {_target(f) for group in (
        ROBOTS, PLOTS, FIGURES, OUTLINES, JOYSTICKS, REPLAYS, CONTROLS, WORLDS, AGENTS, FITS)
        for f in group}
    kinds = [gokart.ROBOT, line_tracker.ROBOT]
    named = {getattr(f, "__qualname__", "") for k in kinds
             for f in (k.factory, k.plots, k.figures, k.outline, k.joystick, k.replay, k.control)
             if f is not None}
    named |= {getattr(c.factory, "__qualname__", "")
              for c in (EXTERNAL, LOCALIZATION, OBSTACLE_DETECTOR)}
    assert named <= typed, named - typed
