"""Simulation: the PyBullet world, robots, sensors and the fixed-step loop."""

from kartci.sim.loop import RunInfo, simulate

__all__ = ["RunInfo", "simulate"]
