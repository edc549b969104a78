"""The line sensor against the source document's characterisation, and its two implementations."""

from __future__ import annotations

import numpy as np
import pytest

from kartci._bullet import pb
from kartci.project import current as active_project
from kartci.robots.line_tracker.characterise import Sweep, sweep
from kartci.robots.line_tracker.params import LineSensorSpec
from kartci.robots.line_tracker.sensors import GEOMETRIC_GRID_PX, LineCamera
from kartci.scenario import load_scenario
from kartci.worlds.line_lab import CircleCourse, LineLabWorld, StraightCourse

OFFSETS = np.round(np.arange(-0.025, 0.02501, 0.0005), 6)


@pytest.fixture(scope="module")
def geometric_and_rendered() -> tuple[Sweep, Sweep]:
    spec = load_scenario("line_straight", project=active_project())
    return (sweep(spec, "lt0", OFFSETS, mode="geometric"),
            sweep(spec, "lt0", OFFSETS, mode="rendered"))


def test_rendered_and_geometric_sensors_agree(geometric_and_rendered: tuple[Sweep, Sweep]) -> None:
    """Stated tolerance: 0.03 luminance per camera at the default 24 x 24 px (one rendered
    pixel column is 1/24 of the image); the fitted slopes within 5 %."""
    geo, ren = geometric_and_rendered
    assert np.abs(geo.left - ren.left).max() < 0.03
    assert np.abs(geo.right - ren.right).max() < 0.03
    assert ren.fit()[0] == pytest.approx(geo.fit()[0], rel=0.05)


Pair = tuple[Sweep, Sweep]


def test_characterisation_matches_the_source_documents_slope_and_linear_range(
        geometric_and_rendered: Pair) -> None:
    geo, ren = geometric_and_rendered
    for s in (geo, ren):
        slope, intercept, r2 = s.fit(0.008)
        assert slope == pytest.approx(39.4022, rel=0.15)  # source document Eq. 6.12
        assert abs(intercept) < 0.02
        assert r2 > 0.97  # quasi-linear within +-8 mm
    # beyond +-8 mm the difference stops growing (the source document's plateau), then falls to zero
    d = geo.difference
    inside = np.abs(OFFSETS) <= 0.008
    assert np.abs(d[~inside]).max() <= np.abs(d[inside]).max() + 1e-9
    assert abs(d[np.argmin(np.abs(OFFSETS - 0.025))]) < 0.05


def test_each_camera_dims_over_the_line_and_sees_white_far_away(geometric_and_rendered: Pair
                                                                ) -> None:
    geo, _ = geometric_and_rendered
    light = load_scenario("line_straight", project=active_project()).world.light_level  # type: ignore[attr-defined]
    assert geo.left[0] == pytest.approx(light) and geo.right[-1] == pytest.approx(light)
    assert geo.left.min() < 0.5 * light
    # the two cameras are 0.01 m apart: their curves are shifted copies of each other
    shift = round(0.01 / 0.0005)
    assert geo.left[:-shift] == pytest.approx(geo.right[shift:], abs=1e-9)


def test_wider_field_of_view_flattens_the_response() -> None:
    spec = load_scenario("line_straight", project=active_project())
    slopes = [sweep(spec, "lt0", OFFSETS, fov_rad=f).fit()[0] for f in (0.75, 1.2, 1.4, 2.0)]
    assert slopes[0] > slopes[1] > slopes[2] > slopes[3]
    assert abs(slopes[3]) < 1.0  # the dead zone beyond 2 atan(12 / 14.5) = 1.38 rad (Eq. 5.2)


def _luminances_before(cam: LineCamera, poses: list[tuple[np.ndarray, np.ndarray]]
                       ) -> list[float]:
    """The geometric camera as it was computed before its in-place rewrite (one numpy
    expression per step, `rel @ u` for a straight line's progress, np.clip, ndarray.mean)."""
    pos, rot = np.array([p for p, _ in poses]), np.array([r for _, r in poses])
    t = np.tan(cam.spec.fov_rad / 2)
    u = (np.arange(GEOMETRIC_GRID_PX) + 0.5) / GEOMETRIC_GRID_PX * 2.0 - 1.0
    uu, vv = np.meshgrid(u, u)
    uv = np.stack([uu.ravel(), vv.ravel()], axis=1) * t
    dirs = uv[:, :1] * rot[:, None, :, 1] + uv[:, 1:] * rot[:, None, :, 2] + rot[:, None, :, 0]
    xy = (pos[:, None, :2] - (pos[:, None, 2:] / dirs[:, :, 2:]) * dirs[:, :, :2]).reshape(-1, 2)
    pixel = max(2.0 * z * t / GEOMETRIC_GRID_PX for z in pos[:, 2].tolist())
    means = _ink_before(cam.world, xy, pixel).reshape(len(poses), -1).mean(axis=1)
    return [float(cam.world.light_level * (1.0 - m)) for m in means]


def _ink_before(world: LineLabWorld, xy: np.ndarray, pixel: float) -> np.ndarray:
    """The courses' ink_coverage before its in-place rewrite."""
    course, half = world.course, world.line_width_m / 2.0
    if isinstance(course, StraightCourse):
        d = np.subtract(course.end_m, course.start_m)
        u = d / np.linalg.norm(d)
        rel = xy - np.asarray(course.start_m)
        along = rel @ u
        off = rel[..., 1] * u[0] - rel[..., 0] * u[1]
    else:
        rel = xy - np.asarray(course.center_m)
        off = course.radius_m - np.hypot(rel[..., 0], rel[..., 1])
    ink = np.clip((half - np.abs(off)) / pixel + 0.5, 0.0, 1.0)
    if isinstance(course, StraightCourse):
        total = course.length_m()
        ink = ink * np.clip(along / pixel + 0.5, 0, 1)
        ink = ink * np.clip((total - along) / pixel + 0.5, 0, 1)
    out: np.ndarray = ink
    return out


@pytest.mark.parametrize("course", [
    StraightCourse(), StraightCourse(start_m=(0.1, 0.2), end_m=(1.3, 2.9)),
    CircleCourse(center_m=(0.3, -0.2), radius_m=0.362)], ids=["straight", "diagonal", "circle"])
def test_geometric_camera_gives_the_bits_it_gave_before(course: StraightCourse | CircleCourse
                                                        ) -> None:
    """Random camera poses over the line, its ends included, most looking down, some tilted
    up to the horizon and beyond: the same floats as the computation it replaced."""
    world = LineLabWorld(course=course)
    cam = LineCamera(0, LineSensorSpec(), world)
    rng = np.random.default_rng(7)
    length = course.length_m()
    for k in range(300):
        along = rng.uniform(-0.02, 0.02) + (length if k % 3 == 1 else 0.0)
        if k % 3 == 2:
            along = rng.uniform(0.0, length)
        poses = []
        for _ in range(1 + k % 2):
            x, y, h = course.pose_at(along, rng.uniform(-0.03, 0.03))
            tilt = rng.normal(0.0, 0.1 if k % 10 else 1.5)
            quat = pb.getQuaternionFromEuler((rng.normal(0.0, 0.1), np.pi / 2 + tilt, h))
            rot = np.array(pb.getMatrixFromQuaternion(quat)).reshape(3, 3)
            poses.append((np.array([x, y, rng.uniform(0.005, 0.03)]), rot))
        new, old = cam.luminances(poses), _luminances_before(cam, poses)
        assert np.array_equal(new, old, equal_nan=True), (k, new, old)
        xy = np.array(poses[0][0][:2]) + rng.normal(0.0, 0.01, (256, 2))
        pixel = rng.uniform(0.0005, 0.003)
        new_ink = course.ink_coverage(world.line_width_m, xy[:, 0], xy[:, 1], pixel)
        assert np.array_equal(new_ink, _ink_before(world, xy, pixel), equal_nan=True), k


@pytest.mark.parametrize("course", [StraightCourse(), CircleCourse()], ids=["straight", "circle"])
@pytest.mark.parametrize("pixel", [0.0, np.nan, np.inf, 0.002])
def test_ink_of_a_pose_gone_non_finite_is_what_it_was_not_an_exception(
        course: StraightCourse | CircleCourse, pixel: float) -> None:
    """A controller that drives the state to NaN makes the camera's pixel size 0 or NaN and its
    points NaN: the ink is the old computation's (NaN, inf), never a ZeroDivisionError, so
    the run ends on its non-finite state and says so (tests/runner/test_crash.py)."""
    world = LineLabWorld(course=course)
    xy = np.array([[0.1, 0.0], [np.nan, 0.0], [0.2, np.inf], [-0.3, 0.01]])
    with np.errstate(all="ignore"):
        new = course.ink_coverage(world.line_width_m, xy[:, 0].copy(), xy[:, 1].copy(),
                                  pixel)
        old = _ink_before(world, xy, pixel)
    assert np.array_equal(new, old, equal_nan=True)
