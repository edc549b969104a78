"""What the worlds around a closed race track share (the hall, the circuit, a team's own):
the track itself (TUMFTM CSV, `Track`), the parameters every such world has
(`TrackWorldParams`, `FloorZone`) and the topics it publishes at t = 0. The simulated base,
`kartci.worlds.track.world.TrackWorld`, is imported on its own: this package loads no PyBullet,
so metrics and localization read a recorded track without it.
"""

from kartci.worlds.track.model import (
    OBSTACLES_TOPIC,
    TRACK_TOPIC,
    Track,
    load_track,
    parse_csv,
    track_from_rows,
    track_from_text,
    write_csv,
)
from kartci.worlds.track.params import FloorZone, TrackWorldParams

__all__ = ["OBSTACLES_TOPIC", "TRACK_TOPIC", "FloorZone", "Track", "TrackWorldParams",
           "load_track", "parse_csv", "track_from_rows", "track_from_text", "write_csv"]
