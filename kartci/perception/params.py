"""The obstacle detector's parameters; units in the key names."""

from __future__ import annotations

from pydantic import Field

from kartci.core import NodeParams
from kartci.core.params import Count, Distance_m, Duration_s, Length_m, Period_s, Size_m


class DetectorParams(NodeParams):
    """Lidar obstacle detection against the world's map."""

    period_s: Period_s = Field(0.02, description="node period, s (a scan is processed at "
                               "the first tick after it arrives)")
    map: str | None = Field("winti/hall_map.ply", description="the map (PLY, world frame): "
                            "points near it are the hall, not obstacles; none: no map, every "
                            "obstacle is reported (a foreign log's replay)")
    pose_topic: str = Field("localization/odom", description="where the kart is "
                            "(nav_msgs/Odometry): the localization's estimate, or `odom` for "
                            "ground truth")
    sensor_height_m: Length_m = Field(1.154, description="velodyne_link above base_link, m, "
                                      "until /tf_static says")
    ground_m: Length_m = Field(0.12, description="points lower than this above the floor "
                               "are ground, m (below the scan: a planar LaserScan has no ground)")
    top_m: Size_m = Field(2.2, description="points higher than this are not "
                          "obstacles a kart meets (ceiling, walls' tops), m")
    map_clearance_m: Size_m = Field(0.3, description="points this close (x, y) to "
                                    "the map are the hall, m")
    max_range_m: Size_m = Field(25.0, description="points farther away are ignored, m")
    cluster_gap_m: Size_m = Field(0.5, description="points closer than this are one "
                                  "object, m")
    min_points: Count = Field(3, description="smaller clusters are noise")
    gate_m: Size_m = Field(1.0, description="a cluster this close to a track's "
                           "prediction updates it, m")
    dynamic_mps: float = Field(0.5, ge=0.0, le=100.0, description="a track is dynamic once faster "
                               "than this, m/s ...")
    dynamic_m: Distance_m = Field(1.0, description="... and farther than this from where "
                                  "it was first seen, m")
    confirm_hits: Count = Field(2, description="scans a track needs before it is "
                                "published")
    keep_static_s: Duration_s = Field(3.0, description="a static track unseen this long "
                                      "is dropped, s (a box the beams pass over when close)")
    keep_dynamic_s: Duration_s = Field(0.5, description="a dynamic track unseen this long "
                                       "is dropped, s")
    established_hits: Count = Field(10, description="a static track seen in fewer scans "
                                    "is dropped like a dynamic one: fragments of a passing kart "
                                    "(seen a few scans) must not stay as boxes for keep_static_s; "
                                    "a real box is seen for seconds before the kart is close")
