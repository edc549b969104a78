"""Worlds with a closed race track (TUMFTM CSV): where karts start, what they are told about the
track and its obstacles at t = 0, and the floor's friction under each wheel."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from kartci.core import WorldParams
from kartci.errors import SpecError
from kartci.logs import msg
from kartci.scenario.models import Pose2D
from kartci.scenario.yamlio import TRACK_MAX_BYTES, read_text_bounded
from kartci.sim.blocks import Block
from kartci.sim.markers import CUBE, TRACK_MARKERS_TOPIC, array, marker, track_markers
from kartci.sim.world import World
from kartci.worlds.messages import COURSE_TOPIC, path_message
from kartci.worlds.track.model import OBSTACLES_TOPIC, TRACK_TOPIC, load_track
from kartci.worlds.track.params import TrackWorldParams


class TrackWorld(World):
    """A world around a closed track. Subclasses build the bodies; `blocks` are its static
    boxes (what the fast lidar sees) and `ceiling_m` the height of a ceiling, if any."""

    spec: TrackWorldParams
    CONE_FRICTION = False  # karts' tyre forces come from tyres.py; their wheels are frictionless

    def __init__(self, spec: WorldParams, dt_s: float, blocks: list[Block],
                 ceiling_m: float) -> None:
        assert isinstance(spec, TrackWorldParams)  # the world registry chose this class by kind
        self.track_file = Path(spec.track)
        self.track = load_track(self.track_file)
        self.blocks, self.ceiling_m = blocks, ceiling_m
        super().__init__(spec, dt_s)

    def start_pose(self, start: Pose2D) -> tuple[float, float, float]:
        """x, y (m) and yaw (rad) of a start given along the track's centreline; a start beside
        the track is bad input (the scenario model cannot check it: it has not read the track)."""
        right_m, left_m = self.track.widths_at(start.along_m)
        if not -right_m <= start.lateral_m <= left_m:
            raise SpecError(f"start.lateral_m: {start.lateral_m:g} m is off the track "
                            f"{self.track_file.name} at along_m {start.along_m:g} m: it must be "
                            f"within {-right_m:.2f} m .. {left_m:.2f} m of the centreline there")
        x, y, yaw = self.track.pose_at(start.along_m, start.lateral_m)
        return x, y, yaw + start.heading_rad

    def static_messages(self) -> list[tuple[str, Any]]:
        """The course, the track itself (the log is self-contained), the obstacles, and markers
        of the track for Foxglove and RViz."""
        step = max(1, len(self.track.xy) // 400)
        xy = self.track.xy[::step]
        left, right = (edge[::step] for edge in self.track.bounds())
        return [(COURSE_TOPIC, path_message(xy)),
                (TRACK_TOPIC, msg("std_msgs/msg/String",
                                  data=read_text_bounded(self.track_file, TRACK_MAX_BYTES))),
                (OBSTACLES_TOPIC, obstacle_markers(self.spec.obstacles)),
                (TRACK_MARKERS_TOPIC, track_markers(xy, left, right))]

    def friction_at(self, x: float, y: float) -> float:
        """Floor friction under a point: the zone it is in, else the world's floor."""
        f = self.spec.floor_friction
        for z in self.spec.zones:
            if z.min_m[0] <= x <= z.max_m[0] and z.min_m[1] <= y <= z.max_m[1]:
                f = z.friction
        return f


def obstacle_markers(obstacles: Any) -> Any:
    """Static obstacles as CUBE markers (ground truth; Foxglove draws them too)."""
    return array([marker("obstacles", i, CUBE, xyz=(b.center_m[0], b.center_m[1], b.size_m[2] / 2),
                         yaw_rad=b.yaw_rad, scale=b.size_m, rgba=(0.8, 0.3, 0.1, 1.0))
                  for i, b in enumerate(obstacles)])
