"""Motion compensation: every point into the sensor frame at the scan's stamp.

A Velodyne revolution takes 1 / rate seconds; the point at azimuth a (counter-clockwise from
x, as the simulated head turns) was measured (1 - a / 2 pi) / rate before the stamp, in the
frame the sensor had then. With the sensor's twist over the revolution taken as constant
(velocity (vx, vy) in its own frame, yaw rate w: wheel odometry, the filter's lateral velocity
and the gyro), that frame sits at yaw -w tau and at the arc travelled back, seen from the frame
at the stamp. vy matters on a sliding kart: 3 m/s sideways is 15 cm over half a revolution."""

from __future__ import annotations

import numpy as np

Array = np.ndarray


def deskew(xyz: Array, v_mps: float, w_radps: float, rate_hz: float,
           vy_mps: float = 0.0) -> Array:
    """Points (N, 3) in their momentary sensor frames -> the sensor frame at the stamp."""
    azimuth = np.mod(np.arctan2(xyz[:, 1], xyz[:, 0]), 2 * np.pi)
    tau = (1.0 - azimuth / (2 * np.pi)) / rate_hz  # how long before the stamp, s
    yaw = -w_radps * tau
    # the earlier frame's origin in the stamp's frame: driven back along the arc,
    # -integral over [0, tau] of R(-w t) (vx, vy) dt
    if abs(w_radps) > 1e-6:
        sn, cs = np.sin(w_radps * tau) / w_radps, (1.0 - np.cos(w_radps * tau)) / w_radps
    else:
        sn, cs = tau, np.zeros_like(tau)
    ox = -(sn * v_mps + cs * vy_mps)
    oy = cs * v_mps - sn * vy_mps
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.empty_like(xyz)
    out[:, 0] = ox + c * xyz[:, 0] - s * xyz[:, 1]
    out[:, 1] = oy + s * xyz[:, 0] + c * xyz[:, 1]
    out[:, 2] = xyz[:, 2]
    return out
