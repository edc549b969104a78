"""Simulation: the PyBullet world, robots, sensors, the stepping `Session` and the loop."""

from kartci.sim.loop import simulate
from kartci.sim.session import RunInfo, Session, StepResult, build_world, make_world

__all__ = ["RunInfo", "Session", "StepResult", "build_world", "make_world", "simulate"]
