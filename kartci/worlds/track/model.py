"""Closed race tracks in the TUMFTM racetrack-database CSV format, and where a point is on one.

`# x_m,y_m,w_tr_right_m,w_tr_left_m`: centreline points of a closed loop (no repeated point) with
the free width to each side. The centreline is a periodic cubic spline through the points
(scipy), sampled densely; projections use a KD-tree over the samples.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from kartci.errors import SpecError
from kartci.scenario.yamlio import TRACK_MAX_BYTES, read_text_bounded

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

    from kartci.worlds.track.params import TrackWorldParams

Array = NDArray[np.float64]
SAMPLE_M = 0.05  # spacing of the dense centreline samples


@dataclass(frozen=True)
class Track:
    """A closed track: dense centreline samples, arc length, headings and widths."""

    name: str
    s: Array  # arc length of each sample, m (0 at the first CSV point = start/finish line)
    xy: Array  # (n, 2) centreline, m
    heading: Array  # rad
    curvature: Array  # 1/m, left turn positive
    w_right: Array  # m
    w_left: Array  # m
    length_m: float
    _tree: cKDTree = field(repr=False, compare=False, hash=False)

    def _index(self, s_m: float) -> int:
        """The centreline sample nearest arc length `s_m` (m, any lap)."""
        return round((s_m % self.length_m) / self.length_m * len(self.s)) % len(self.s)

    def widths_at(self, s_m: float) -> tuple[float, float]:
        """The track's free width (right, left) of the centreline at arc length `s_m`, m."""
        i = self._index(s_m)
        return float(self.w_right[i]), float(self.w_left[i])

    def curvature_at(self, s_m: float) -> float:
        """The centreline's curvature at arc length `s_m`, 1/m, left turns positive."""
        return float(self.curvature[self._index(s_m)])

    def pose_at(self, s_m: float, lateral_m: float = 0.0) -> tuple[float, float, float]:
        """Point `lateral_m` left of the centreline at arc length `s_m`, and the heading there."""
        i = self._index(s_m)
        h = self.heading[i]
        x, y = self.xy[i]
        return float(x - np.sin(h) * lateral_m), float(y + np.cos(h) * lateral_m), float(h)

    def project(self, xy: Array) -> tuple[Array, Array, Array, Array]:
        """Arc length, signed lateral offset (left +), and the widths right / left there."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        _, idx = self._tree.query(xy)
        rel = xy - self.xy[idx]
        h = self.heading[idx]
        along = rel[:, 0] * np.cos(h) + rel[:, 1] * np.sin(h)
        lateral = -rel[:, 0] * np.sin(h) + rel[:, 1] * np.cos(h)
        s = (self.s[idx] + along) % self.length_m
        return s, lateral, self.w_right[idx], self.w_left[idx]

    def bounds(self) -> tuple[Array, Array]:
        """Left and right edges as (n, 2) polylines."""
        n = np.column_stack([-np.sin(self.heading), np.cos(self.heading)])
        return self.xy + n * self.w_left[:, None], self.xy - n * self.w_right[:, None]


@dataclass(frozen=True)
class TrackCourse:
    """A track's centreline as the course kind-neutral code asks about
    (`kartci.core.course.Course`): a loop, unwrapped over laps, its free widths the room a
    robot has before it is off the track."""

    track: Track

    @property
    def closed(self) -> bool:
        """A track is a loop."""
        return True

    def length_m(self) -> float:
        """One lap of the centreline, m."""
        return self.track.length_m

    def pose_at(self, along_m: float, lateral_m: float) -> tuple[float, float, float]:
        """A point `along_m` down the centreline and `lateral_m` left of it, and the heading."""
        return self.track.pose_at(along_m, lateral_m)

    def offset_m(self, xy: Array) -> Array:
        """Signed distance of points (..., 2) from the centreline, left positive, m."""
        xy = np.asarray(xy, dtype=float)
        out: Array = self.track.project(xy)[1].reshape(xy.shape[:-1])
        return out

    def progress_m(self, xy: Array) -> Array:
        """Arc length of each point of a time-ordered track (..., 2), unwrapped over laps, m
        (from the first point's lap)."""
        xy = np.asarray(xy, dtype=float)
        s = self.track.project(xy)[0]
        length = self.track.length_m
        out: Array = np.unwrap(s, period=length).reshape(xy.shape[:-1])
        return out

    def polyline(self, n: int = 400) -> Array:
        """At most `n` centreline points, closed (the first repeated)."""
        xy = self.track.xy[::-(-len(self.track.xy) // max(n - 1, 1))]  # ceil: <= n - 1
        return np.vstack([xy, xy[:1]])

    def curvature_at(self, along_m: float) -> float:
        """The centreline's curvature at `along_m`, 1/m, left positive."""
        return self.track.curvature_at(along_m)

    def room_m(self, along_m: float) -> tuple[float, float]:
        """The track's free width right and left of the centreline there, m."""
        return self.track.widths_at(along_m)


def track_course(params: TrackWorldParams) -> TrackCourse:
    """A track world's course (`WorldKind.course`): its track's centreline."""
    return TrackCourse(load_track(Path(params.track)))


def parse_csv(path: Path, text: str) -> Array:
    """Rows of a TUMFTM CSV file's text (`path` names it in messages)."""
    try:
        rows = np.loadtxt(io.StringIO(text), delimiter=",", comments="#", ndmin=2)
    except ValueError as err:  # numpy's message quotes the row: the file may be any file
        raise SpecError(f"{path}{_first_bad_cell(text)}: not a TUMFTM track CSV "
                        "(x_m,y_m,w_tr_right_m,w_tr_left_m)") from err
    if rows.shape[1] != 4 or len(rows) < 4:
        raise SpecError(f"{path}: expected at least 4 rows of x_m,y_m,w_tr_right_m,w_tr_left_m")
    if np.allclose(rows[0, :2], rows[-1, :2]):
        raise SpecError(f"{path}: the loop repeats its first point at the end; drop the last row")
    if (rows[:, 2:] <= 0).any():
        raise SpecError(f"{path}: track widths must be positive")
    return rows


def _first_bad_cell(text: str) -> str:
    """`:LINE:COLUMN` (1-based) of the first cell that is not a number, or `:LINE` of the first
    row without 4 cells: where np.loadtxt stopped, told without quoting the file."""
    for number, line in enumerate(text.splitlines(), 1):
        cells = line.split("#", 1)[0].split(",")
        if len(cells) == 1 and not cells[0].strip():
            continue
        if len(cells) != 4:
            return f":{number}"
        column = 1
        for cell in cells:
            try:
                float(cell)
            except ValueError:
                return f":{number}:{column + len(cell) - len(cell.lstrip())}"
            column += len(cell) + 1
    return ""


TRACK_TOPIC = "/kartci/track"  # std_msgs/String: the track CSV, published at t = 0
OBSTACLES_TOPIC = "/kartci/obstacles"  # visualization_msgs/MarkerArray: boxes, at t = 0


@cache
def load_track(path: Path) -> Track:
    """A track from a TUMFTM CSV file, read within TRACK_MAX_BYTES; cached by path."""
    return track_from_rows(parse_csv(path, read_text_bounded(path, TRACK_MAX_BYTES)), path)


def track_from_text(text: str, name: str) -> Track:
    """A track from CSV text, as recorded in a run log."""
    return track_from_rows(parse_csv(Path(name), text), Path(name))


def track_from_rows(rows: Array, path: Path) -> Track:
    """The Track splined through CSV rows; refuses coincident points and splined widths <= 0."""
    from scipy.interpolate import CubicSpline  # start-up: +0.25 s (scipy.optimize) on import
    from scipy.spatial import cKDTree  # start-up: +0.3 s, not for a log without a track

    pts = np.vstack([rows, rows[:1]])
    seg = np.hypot(*np.diff(pts[:, :2], axis=0).T)
    if (seg < 1e-6).any():
        raise SpecError(f"{path}: two consecutive points coincide")
    knots = np.concatenate([[0.0], np.cumsum(seg)])
    spline = CubicSpline(knots, pts, bc_type="periodic")
    u = np.arange(0.0, knots[-1], SAMPLE_M)
    p, d1, d2 = spline(u), spline(u, 1), spline(u, 2)
    step = np.hypot(*np.diff(np.vstack([p[:, :2], p[:1, :2]]), axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(step)[:-1]])
    speed = np.hypot(d1[:, 0], d1[:, 1])
    curvature = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / speed**3
    xy = p[:, :2]
    if (p[:, 2:] <= 0).any():
        raise SpecError(f"{path}: the spline through the widths goes non-positive somewhere")
    return Track(path.stem, s, xy, np.arctan2(d1[:, 1], d1[:, 0]), curvature, p[:, 2], p[:, 3],
                 float(step.sum()), cKDTree(xy))


def write_csv(path: Path, rows: Array, comment: str = "") -> None:
    """Rows as a TUMFTM CSV (4 decimals), with an optional comment above the column header."""
    header = "x_m,y_m,w_tr_right_m,w_tr_left_m"
    if comment:
        header = comment.rstrip("\n") + "\n" + header
    np.savetxt(path, rows, delimiter=",", fmt="%.4f", header=header, comments="# ")
