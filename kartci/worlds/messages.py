"""What every world kind tells robots at t = 0 about its course: the line's axis or the
track's centreline as a nav_msgs/Path."""

from __future__ import annotations

from typing import Any

from kartci.logs import header, msg
from kartci.sim.messages import WORLD_FRAME, pose

COURSE_TOPIC = "/kartci/course"  # nav_msgs/Path: the line's axis or the track's centreline


def path_message(pts: Any) -> Any:
    """A polyline as nav_msgs/Path in the world frame."""
    poses = [msg("geometry_msgs/msg/PoseStamped", header=header(0, WORLD_FRAME),
                 pose=pose((float(x), float(y), 0.0), (0.0, 0.0, 0.0, 1.0))) for x, y in pts]
    return msg("nav_msgs/msg/Path", header=header(0, WORLD_FRAME), poses=poses)
