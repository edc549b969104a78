"""Simulation: the PyBullet world, robots, sensors and the fixed-step loop."""

from kartci.sim.loop import RunInfo, build_world, make_world, simulate

__all__ = ["RunInfo", "build_world", "make_world", "simulate"]
