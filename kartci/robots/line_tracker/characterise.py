"""Reproduce the source document's line-sensor characterisation (Fig. 5.2.2.2, 6.3.1 and 5.2.2.3).

The robot, parallel to a straight line, is placed at a series of lateral offsets across it (as
the source document's plugin did with SetWorldPose) and both cameras are read at each, without
noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kartci._bullet import pb
from kartci.robots.line_tracker.body import LineTracker
from kartci.robots.line_tracker.params import LineTrackerSensors, line_parts
from kartci.robots.line_tracker.sensors import LineCamera
from kartci.scenario import Scenario
from kartci.sim.urdf import urdf_path
from kartci.worlds.line_lab.world import LineLab


@dataclass(frozen=True)
class Sweep:
    """Camera luminances (left, right) at each lateral offset of a sweep (m, left of the line +)."""

    offsets_m: np.ndarray
    left: np.ndarray
    right: np.ndarray

    @property
    def difference(self) -> np.ndarray:
        """Left minus right: the signal the controller estimates its offset from."""
        out: np.ndarray = self.left - self.right
        return out

    def fit(self, half_range_m: float = 0.008) -> tuple[float, float, float]:
        """Least-squares line y = slope d + intercept over |d| <= half_range; and its R^2."""
        m = np.abs(self.offsets_m) <= half_range_m + 1e-12
        d, y = self.offsets_m[m], self.difference[m]
        slope, intercept = np.polyfit(d, y, 1)
        resid = y - (slope * d + intercept)
        total = float(((y - y.mean()) ** 2).sum())
        r2 = 1.0 - float(resid @ resid) / total if total > 0 else 0.0  # flat: no relation
        return float(slope), float(intercept), r2


def sweep(scenario: Scenario, agent: str, offsets_m: np.ndarray, fov_rad: float | None = None,
          mode: str | None = None) -> Sweep:
    """Camera outputs with the sensor midpoint at each lateral offset (left of the line +)."""
    spec = scenario.agents[agent]
    lab, _ = line_parts(scenario, agent)
    sensors = spec.sensors
    assert isinstance(sensors, LineTrackerSensors)  # validated by the robot kind
    sensor = sensors.line_sensor.model_copy(update={
        k: v for k, v in (("fov_rad", fov_rad), ("mode", mode)) if v is not None})
    world = LineLab(lab, scenario.physics.dt_s)
    try:
        robot = LineTracker(world.client, spec, lab,
                            urdf_path(spec.model).parent, scenario.physics.dt_s)
        camera = LineCamera(world.client, sensor, lab, world)
        start = robot.state()
        yaw = float(pb.getEulerFromQuaternion(start.quat)[2])
        normal = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        base0 = np.asarray(start.xyz) - spec.start.lateral_m * normal
        left, right = [], []
        for d in offsets_m:
            robot.reset_pose(base0 + d * normal, start.quat)
            st = robot.state()
            left.append(camera.luminance(*robot.frame_pose("line_camera_left", st)))
            right.append(camera.luminance(*robot.frame_pose("line_camera_right", st)))
        return Sweep(np.asarray(offsets_m, dtype=float), np.array(left), np.array(right))
    finally:
        world.close()
