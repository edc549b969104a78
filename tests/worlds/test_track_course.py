"""A track's centreline answers what kind-neutral code asks of a course (`Course`): the hall's
and the circuit's world kinds hand it to kartci.gym without a simulator."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kartci import core
from kartci.core.course import Course
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.worlds.track import track_from_rows
from kartci.worlds.track.model import TrackCourse

RADIUS_M = 10.0


@pytest.fixture
def ring() -> TrackCourse:
    """A circular track of radius 10 m, 1.5 m free to the right and 2 m to the left, driven
    counter-clockwise from (10, 0)."""
    a = np.linspace(0.0, 2 * np.pi, 72, endpoint=False)
    rows = np.column_stack([RADIUS_M * np.cos(a), RADIUS_M * np.sin(a), np.full(72, 1.5),
                            np.full(72, 2.0)])
    return TrackCourse(track_from_rows(rows, Path("ring.csv")))


def test_a_track_answers_the_course_questions(ring: TrackCourse) -> None:
    assert isinstance(ring, Course) and ring.closed
    assert ring.length_m() == pytest.approx(2 * np.pi * RADIUS_M, rel=1e-3)
    assert ring.curvature_at(7.0) == pytest.approx(1 / RADIUS_M, rel=1e-2)  # left turn
    assert ring.room_m(3.0) == pytest.approx((1.5, 2.0))
    x, y, yaw = ring.pose_at(0.0, 0.5)
    assert (x, y, yaw) == pytest.approx((RADIUS_M - 0.5, 0.0, np.pi / 2), abs=1e-2)
    assert ring.offset_m(np.array([[9.5, 0.0], [0.0, 10.3]])) == pytest.approx(
        [0.5, -0.3], abs=1e-3)  # inside is left
    loop = ring.polyline(50)
    assert len(loop) <= 50 and loop[0] == pytest.approx(loop[-1])


def test_progress_runs_on_over_laps(ring: TrackCourse) -> None:
    """Two laps of points in time order: progress grows past one lap's length, unwrapped."""
    a = np.linspace(0.0, 4 * np.pi - 0.1, 400)
    pts = np.column_stack([RADIUS_M * np.cos(a), RADIUS_M * np.sin(a)])
    progress = ring.progress_m(pts)
    assert np.all(np.diff(progress) > 0)
    assert progress[-1] - progress[0] == pytest.approx((4 * np.pi - 0.1) * RADIUS_M, rel=2e-3)


@pytest.mark.parametrize("scenario", ["mpcc_lap", "mpcc_circuit", "line_circle"])
def test_world_kinds_hand_out_their_course(scenario: str) -> None:
    spec = load_scenario(scenario, project=active_project())
    make = core.WORLDS.get(spec.world.kind).course
    assert make is not None
    course = make(spec.world)
    assert isinstance(course, Course) and course.closed and course.length_m() > 1.0
