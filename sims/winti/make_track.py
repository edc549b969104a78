"""Draw the hall track: a periodic spline through hand-placed control points, written in the
TUMFTM format. Run once; the CSV is the data kartci reads (`python sims/winti/make_track.py`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from kartci.track import write_csv

# Control points (m), counter-clockwise, inside a 32 m x 20 m hall; start/finish on the main
# straight. Hairpin at the east end, a fast sweeper north, a chicane on the back straight.
CONTROL = [
    (8.0, 3.2), (14.0, 3.2), (20.0, 3.2), (25.0, 3.5), (28.3, 5.6), (28.5, 9.0), (26.0, 11.0),
    (22.8, 11.6), (20.6, 13.4), (18.4, 15.8), (15.0, 16.6), (12.0, 15.6), (9.0, 16.6),
    (5.6, 16.4), (3.5, 13.6), (3.3, 9.0), (3.6, 5.6), (5.2, 3.6),
]
HALF_WIDTH_M = 1.6
STEP_M = 1.0


def main() -> None:
    pts = np.array(CONTROL + CONTROL[:1])
    seg = np.hypot(*np.diff(pts, axis=0).T)
    t = np.concatenate([[0.0], np.cumsum(seg)])
    spline = CubicSpline(t, pts, bc_type="periodic")
    u = np.arange(0.0, t[-1], STEP_M)
    xy = spline(u)
    rows = np.column_stack([xy, np.full(len(u), HALF_WIDTH_M), np.full(len(u), HALF_WIDTH_M)])
    out = Path(__file__).with_name("track.csv")
    write_csv(out, rows, "Winti hall track (approximation, drawn for kartci; not the real spline)")
    print(f"wrote {out}: {len(rows)} points")


if __name__ == "__main__":
    main()
