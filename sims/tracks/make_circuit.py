"""A club circuit larger than the Winti hall (about 95 x 45 m, 6 m wide), in the TUMFTM format,
for the `circuit` world kind. Run once; the CSV is the data
(`.venv/bin/python sims/tracks/make_circuit.py`). A closed polygon through
hand-placed waypoints, smoothed by a periodic Gaussian; corner radii above 8 m."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from make_tracks import centreline

from kartci.worlds.track import track_from_rows, write_csv

HALF_WIDTH_M = 3.0
WAYPOINTS = [(0, 0), (25, 0), (50, 0), (68, 4), (77, 18), (71, 33), (56, 38), (45, 31),
             (35, 23), (25, 28), (15, 39), (0, 42), (-12, 33), (-15, 16), (-10, 4)]


def main() -> None:
    xy = centreline(WAYPOINTS, smooth_m=6.0)
    rows = np.column_stack([xy, np.full(len(xy), HALF_WIDTH_M), np.full(len(xy), HALF_WIDTH_M)])
    path = Path(__file__).with_name("club.csv")
    write_csv(path, rows, "club: kartci test circuit, larger than the hall (waypoints smoothed)")
    track = track_from_rows(rows, path)
    print(f"club: {track.length_m:.1f} m, tightest radius "
          f"{1 / np.abs(track.curvature).max():.1f} m, extent {np.ptp(xy, axis=0).round(1)} m")


if __name__ == "__main__":
    main()
