"""The obstacle detector's parts: boxes with heading from points, map and ground removal,
tracks that tell a moving box from a standing one; and the detection metric's matching by
hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kartci.metrics.detection import DetectionMetricsParams, _Tally
from kartci.perception.clusters import MapMask, box, clusters, obstacle_points
from kartci.perception.tracker import Tracker


def _faces(cx: float, cy: float, length: float, width: float, yaw: float,
           step: float = 0.05) -> np.ndarray:
    """Points on the four sides of a box 0.5 m high, turned by yaw."""
    u = np.arange(-0.5, 0.5 + 1e-9, step / length) * length
    v = np.arange(-0.5, 0.5 + 1e-9, step / width) * width
    sides = [np.column_stack([u, np.full_like(u, s * width / 2)]) for s in (-1, 1)]
    sides += [np.column_stack([np.full_like(v, s * length / 2), v]) for s in (-1, 1)]
    xy = np.concatenate(sides)
    c, s = math.cos(yaw), math.sin(yaw)
    xy = xy @ np.array([[c, s], [-s, c]]) + (cx, cy)
    return np.column_stack([xy, np.full(len(xy), 0.4)])


def test_a_box_gets_its_centre_size_and_heading() -> None:
    b = box(_faces(3.0, -2.0, 2.0, 1.0, 0.4))
    assert (b.x, b.y) == pytest.approx((3.0, -2.0), abs=0.02)
    assert (b.length, b.width) == pytest.approx((2.0, 1.0), abs=0.03)
    assert b.yaw == pytest.approx(0.4, abs=0.01)


def test_map_floor_and_ceiling_points_go_obstacles_stay() -> None:
    wall = np.column_stack([np.linspace(0, 10, 200), np.zeros(200), np.full(200, 1.0)])
    mask = MapMask(wall, 0.12, 2.2)
    scan = np.concatenate([wall + np.array([0.0, 0.05, 0.0]),  # the wall, 5 cm off: the map
                           np.column_stack([np.random.default_rng(0).uniform(0, 10, (300, 2)),
                                            np.full(300, 0.02)]),  # floor
                           _faces(5.0, 3.0, 0.5, 0.5, 0.0),  # an obstacle
                           _faces(8.0, 3.0, 0.5, 0.5, 0.0) + np.array([0.0, 0.0, 3.0])])
    pts = obstacle_points(scan, np.array([5.0, 1.0]), mask, 0.12, 2.2, 0.3, 25.0)
    found = clusters(pts, 0.5, 3)
    assert len(found) == 1
    assert (found[0].x, found[0].y) == pytest.approx((5.0, 3.0), abs=0.02)


def test_tracks_tell_moving_from_standing() -> None:
    """A box standing at (5, 0) and one moving at 2 m/s along y, scanned at 10 Hz with the
    standing one's centre wandering by 0.2 m (other faces coming into view)."""
    tr = Tracker(1.0, 0.5, 1.0)
    rng = np.random.default_rng(0)
    for k in range(20):
        t = 0.1 * k
        still = box(_faces(5.0 + rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), 0.5, 0.5,
                           0.0))
        moving = box(_faces(0.0, 2.0 * t, 2.0, 1.0, math.pi / 2))
        tr.update(t, [still, moving])
    assert len(tr.tracks) == 2
    by_x = sorted(tr.tracks, key=lambda track: float(track.xy[0]))
    assert by_x[0].moved and not by_x[1].moved
    assert by_x[0].v == pytest.approx([0.0, 2.0], abs=0.3)
    assert tr.heading(by_x[0]) == pytest.approx(math.pi / 2, abs=0.1)


def test_a_briefly_seen_fragment_is_dropped_sooner_than_an_established_box() -> None:
    """A box seen for 2 s and a fragment seen in 3 scans, both then unseen for 1 s: with
    `established_hits` 10 the fragment goes after keep_dynamic_s (0.5 s), the box stays for
    keep_static_s (3 s); with 1 (no distinction) both stay."""
    def tracker(established: int) -> list[float]:
        tr = Tracker(1.0, 0.5, 1.0)
        for k in range(20):
            boxes = [box(_faces(5.0, 0.0, 0.5, 0.5, 0.0))]
            if k < 3:
                boxes.append(box(_faces(0.0, 5.0, 0.5, 0.5, 0.0)))
            tr.update(0.1 * k, boxes)
        tr.update(2.9, [])
        tr.prune(2.9, 3.0, 0.5, established)
        return sorted(round(float(track.xy[0]), 1) for track in tr.tracks)

    assert tracker(10) == [5.0]
    assert tracker(1) == [0.0, 5.0]


def test_detection_tally_by_hand() -> None:
    """Truth: two static boxes in range, one far away, one dynamic kart in range. Detections:
    one static box 0.2 m off, the kart called static, one ghost."""
    t = _Tally()
    truth = [(3.0, 0.0, False), (0.0, 5.0, False), (40.0, 0.0, False), (-4.0, 0.0, True)]
    dets = [(3.2, 0.0, False), (-4.5, 0.0, False), (8.0, 8.0, False)]
    t.frame((0.0, 0.0), dets, truth, DetectionMetricsParams())
    assert (t.truth, t.found) == (3, 2)  # recall 2 / 3
    assert (t.dets, t.true_dets) == (3, 2)  # precision 2 / 3
    assert t.errors == pytest.approx([0.2, 0.5])
    assert t.right == 1  # the kart was called static
