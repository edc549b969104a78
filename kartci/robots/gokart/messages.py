"""What only the kart knows of its own messages: how a log's tables flatten them, which of
their fields are measured on the wall clock, and the command an external stack may send it.
Registered with the kind (`ROBOT`), read by the kind-neutral log, diff and bridge code."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from kartci.core import Flattener, fields


def _tyres(m: Any) -> dict[str, Any]:
    return {f"{w}.{k}": getattr(m, k)[i] for i, w in enumerate(m.wheel)
            for k in ("fx_n", "fy_n", "grip_n")}


FLATTENERS: Mapping[str, Flattener] = {
    "kartci_msgs/msg/KartCommand": fields("steering_wheel_angle_rad", "acceleration_mps2",
                                          "brake_mps2", "reverse", "emergency_stop"),
    "kartci_msgs/msg/SolverStats": fields("success", "status", "solve_ms", "iterations",
                                          "cost", "failures", "max_slack_m"),
    "kartci_msgs/msg/TyreForces": _tyres,
}
# the MPCC (its mpcc.controller): time.perf_counter() around the solve, ms
WALL_CLOCK: Mapping[str, tuple[str, ...]] = {"kartci_msgs/msg/SolverStats": ("solve_ms",)}
# an external stack may answer with the kart's own command; applied on its `cmd` topic
COMMANDS: Mapping[str, str] = {"kartci_msgs/msg/KartCommand": "cmd"}
