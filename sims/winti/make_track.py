"""Draw the hall track from straights and arcs and write it in the TUMFTM format.

Run once; the CSV is the data kartci reads (`.venv/bin/python sims/winti/make_track.py`).
Counter-clockwise, start/finish at (8, 3.2) heading east: main straight, a 180 deg east turn
(two R 5 m quarters), a chicane (two 30 deg R 6 m arcs) on the back straight, and a 180 deg west
turn (two R 4.5 m quarters). Corner radii stay above the kart's ~2.6 m minimum turning radius.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from kartci.worlds.track import write_csv

HALF_WIDTH_M = 2.0
STEP_M = 1.0
START = (8.0, 3.2, 0.0)  # x, y, heading
# (length m, curvature 1/m): left turns positive
SEGMENTS = [
    (14.0, 0.0), (math.pi / 2 * 5.0, 1 / 5.0), (1.8, 0.0), (math.pi / 2 * 5.0, 1 / 5.0),
    (5.0, 0.0), (math.pi / 6 * 6.0, -1 / 6.0), (math.pi / 6 * 6.0, 1 / 6.0), (3.0, 0.0),
    (math.pi / 2 * 4.5, 1 / 4.5), (4.4, 0.0), (math.pi / 2 * 4.5, 1 / 4.5),
]


def centreline() -> np.ndarray:
    x, y, h = START
    pts = []
    ds = 0.01
    for length, kappa in SEGMENTS:
        for _ in range(round(length / ds)):
            pts.append((x, y))
            x += math.cos(h + kappa * ds / 2) * ds
            y += math.sin(h + kappa * ds / 2) * ds
            h += kappa * ds
    dense = np.array(pts)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(dense, axis=0).T))])
    keep = np.searchsorted(s, np.arange(0.0, s[-1] - STEP_M / 2, STEP_M))
    return dense[keep]


def main() -> None:
    xy = centreline()
    rows = np.column_stack([xy, np.full(len(xy), HALF_WIDTH_M), np.full(len(xy), HALF_WIDTH_M)])
    out = Path(__file__).with_name("track.csv")
    write_csv(out, rows, "Winti hall track (approximation, drawn for kartci; not the real spline)")
    print(f"wrote {out}: {len(rows)} points")


if __name__ == "__main__":
    main()
