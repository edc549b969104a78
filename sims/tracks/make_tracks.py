"""Three more tracks for the Winti hall, each of a different character, in the TUMFTM format.

Run once; the CSVs are the data (`.venv/bin/python sims/tracks/make_tracks.py`). Each track is
a closed periodic spline through hand-placed waypoints, kept 0.4 m or more inside the walls and
away from the hall's pillars, with corner radii above the kart's ~3 m turning circle. Use one
with `--set world.track=tracks/<name>.csv`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter1d

from kartci.scenario import load_scenario
from kartci.worlds.hall.world import blocks
from kartci.worlds.track import track_from_rows, write_csv

HALF_WIDTH_M = 1.8
WAYPOINTS = {
    # two 180-degree hairpins (R ~4 m) joined by straights, and a kink on the way back
    "hairpins": [(7, 2.8), (16, 2.6), (25.2, 2.6), (28.45, 3.95), (29.8, 7.2), (28.45, 10.45),
                 (25.2, 11.8), (21.5, 11.6), (17.5, 12.8), (13, 15.6), (10, 17.0),
                 (7.4, 17.2), (4.3, 15.9), (3.0, 12.6), (3.0, 9.5), (3.2, 6.8),
                 (4.25, 4.0)],
    # fast sweepers: long, wide arcs and no tight corner
    "sweepers": [(8, 3.2), (16, 3.0), (23.5, 3.6), (27.8, 6.8), (27.8, 12.2), (24.5, 16.2),
                 (19, 16.9), (13, 15.8), (7.5, 16.6), (3.6, 13.6), (3.4, 7.5), (4.8, 4.2)],
    # a fast straight into a left-right chicane, then a long loop back
    "chicane": [(5, 3.2), (11, 3.2), (16.5, 3.2), (19.5, 4.6), (22.5, 4.6), (25, 3.2),
                (27.6, 4.6), (28.6, 8.5), (27.4, 13), (24, 16.3), (16, 16.8), (8, 16.8),
                (4.2, 14.6), (3.3, 9.5), (3.8, 5)],
}


def check(name: str, rows: np.ndarray) -> str:
    track = track_from_rows(rows, Path(name))
    radius = 1 / np.abs(track.curvature).max()
    hall = load_scenario("mpcc_lap").world
    clear = min(
        float(np.min(np.maximum(np.abs(track.xy - b.center)[:, 0] - b.size[0] / 2,
                                np.abs(track.xy - b.center)[:, 1] - b.size[1] / 2)))
        for b in blocks(hall)) - HALF_WIDTH_M  # type: ignore[arg-type]
    return f"{name}: {track.length_m:.1f} m, tightest radius {radius:.1f} m, {clear:.2f} m to walls"


def centreline(pts: list[tuple[float, float]], smooth_m: float = 2.0) -> np.ndarray:
    """The closed polygon through the waypoints, smoothed by a periodic Gaussian (sigma in
    metres of arc), sampled every metre: round corners without spline overshoot."""
    poly = np.vstack([pts, pts[:1]]).astype(float)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poly, axis=0).T))])
    u = np.arange(0.0, s[-1], 0.05)
    dense = np.column_stack([np.interp(u, s, poly[:, 0]), np.interp(u, s, poly[:, 1])])
    dense = gaussian_filter1d(dense, smooth_m / 0.05, axis=0, mode="wrap")
    return dense[:: round(1.0 / 0.05)]


def main() -> None:
    for name, pts in WAYPOINTS.items():
        xy = centreline(pts)
        rows = np.column_stack([xy, np.full(len(xy), HALF_WIDTH_M), np.full(len(xy),
                                                                          HALF_WIDTH_M)])
        write_csv(Path(__file__).with_name(f"{name}.csv"), rows,
                  f"{name}: kartci test track for the Winti hall (waypoints of a periodic spline)")
        print(check(name, rows))


if __name__ == "__main__":
    main()
