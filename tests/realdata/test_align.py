"""Alignment before APE / RPE (kartci.metrics.alignment): a known transform undone exactly, the
same numbers as evo's command line (-a, -as, --align_origin, --n_to_align) on the same TUM files,
and `kartci score --align` on a log whose estimate is in another frame."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from helpers import evo, evo_exe, kartci
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

from kartci.errors import SpecError
from kartci.metrics.alignment import Alignment, align, umeyama
from kartci.metrics.trajectory import (
    DeltaUnit,
    ErrorStats,
    Relation,
    Trajectory,
    TrajectoryError,
    ape,
    associate,
    rpe,
)
from kartci.project import current as active_project
from kartci.realdata.profile import load_profile

# a known Sim(3): rotated about a tilted axis, shifted, scaled
R_TRUE = Rotation.from_rotvec([0.1, -0.2, 1.1])
T_TRUE = np.array([3.0, -2.0, 0.5])
S_TRUE = 1.7


def _path(seed: int = 0, n: int = 400) -> Trajectory:
    """A 3D loop with varying heading at 20 Hz (not planar: every rotation axis is seen)."""
    t = np.arange(n) * 0.05
    xyz = np.column_stack([4 * np.cos(0.3 * t), 3 * np.sin(0.3 * t), 0.4 * np.sin(0.7 * t)])
    rng = np.random.default_rng(seed)
    quat = Rotation.from_euler("zyx", np.column_stack(
        [0.3 * t, 0.05 * np.sin(t), rng.normal(0, 0.01, n)])).as_quat()
    return Trajectory(t, xyz, quat)


def _moved(tr: Trajectory, scale: float = 1.0) -> Trajectory:
    return Trajectory(tr.t_s, scale * R_TRUE.apply(tr.xyz_m) + T_TRUE,
                      (R_TRUE * tr.rotations()).as_quat())


@pytest.mark.parametrize(("how", "scale"), [(Alignment.SE3, 1.0), (Alignment.SIM3, S_TRUE),
                                            (Alignment.ORIGIN, 1.0)])
def test_a_known_transform_aligns_back_to_zero_error(how: Alignment, scale: float) -> None:
    ref = _path()
    est = _moved(ref, scale)
    assert ape(ref, est).rmse > 1.0
    moved, tf = align(ref, est, how)
    assert ape(ref, moved).rmse == pytest.approx(0.0, abs=1e-9)
    assert ape(ref, moved, Relation.ROTATION_DEG).rmse == pytest.approx(0.0, abs=1e-6)
    # the fitted transform is the inverse of the one applied
    assert tf.scale == pytest.approx(1.0 / scale, rel=1e-12)
    assert np.allclose(tf.rotation, R_TRUE.inv().as_matrix(), atol=1e-12)


def test_se3_cannot_remove_a_scale_and_sim3_fitted_on_the_first_poses_can() -> None:
    ref = _path()
    est = _moved(ref, S_TRUE)
    assert ape(ref, align(ref, est, Alignment.SE3)[0]).rmse > 0.5
    assert ape(ref, align(ref, est, Alignment.SIM3, first=20)[0]).rmse == pytest.approx(
        0.0, abs=1e-9)


def test_degenerate_points_are_refused_with_the_reason() -> None:
    t = np.arange(10.0)
    line = Trajectory.planar(t, t, 0 * t, 0 * t)
    with pytest.raises(TrajectoryError, match="one line"):
        umeyama(line.xyz_m, line.xyz_m, False)
    with pytest.raises(TrajectoryError, match="two or more"):
        align(line, line, Alignment.SE3, first=1)


def _noisy_pair() -> tuple[Trajectory, Trajectory]:
    """The estimate: the reference in another frame (moved, scaled 0.8), noisy and drifting,
    at half the rate with jittered stamps."""
    ref = _path(1, 600)
    rng = np.random.default_rng(2)
    idx = np.arange(0, len(ref), 2)
    sub = ref.take(idx)
    drift = np.column_stack([0.02 * sub.t_s, -0.01 * sub.t_s, 0 * sub.t_s])
    noisy = Trajectory(sub.t_s + rng.normal(0, 0.002, len(idx)),
                       sub.xyz_m + drift + rng.normal(0, 0.05, (len(idx), 3)),
                       (sub.rotations() * Rotation.from_rotvec(
                           rng.normal(0, 0.02, (len(idx), 3)))).as_quat())
    return ref, _moved(noisy, 0.8)


EVO_CASES = [
    (("-a",), Alignment.SE3, None),
    (("-as",), Alignment.SIM3, None),
    (("--align_origin",), Alignment.ORIGIN, None),
    (("-a", "--n_to_align", "40"), Alignment.SE3, 40),
    (("-as", "--n_to_align", "40"), Alignment.SIM3, 40),
]


@pytest.mark.parametrize(("args", "how", "first"), EVO_CASES,
                         ids=["se3", "sim3", "origin", "se3-first40", "sim3-first40"])
def test_aligned_ape_and_rpe_equal_evos(tmp_path: Path, args: tuple[str, ...], how: Alignment,
                                       first: int | None) -> None:
    evo_exe("evo_ape")  # skips, saying how to install it, where evo is absent
    ref, est = _noisy_pair()
    ref.to_tum(tmp_path / "ref.txt")
    est.to_tum(tmp_path / "est.txt")
    r, e = associate(Trajectory.from_tum(tmp_path / "ref.txt"),
                     Trajectory.from_tum(tmp_path / "est.txt"))
    moved, _ = align(r, e, how, first)
    cases: list[tuple[str, tuple[str, ...], Callable[[], ErrorStats]]] = [
             ("evo_ape", (), lambda: ape(r, moved)),
             ("evo_ape", ("-r", "angle_deg"), lambda: ape(r, moved, Relation.ROTATION_DEG)),
             ("evo_rpe", ("-d", "1", "-u", "m"), lambda: rpe(r, moved, 1.0)),
             ("evo_rpe", ("-d", "5", "-u", "f"), lambda: rpe(r, moved, 5, DeltaUnit.FRAMES))]
    for tool, extra, ours in cases:
        theirs = evo(tmp_path, tool, *args, *extra)
        stats = ours()
        for key in ("rmse", "mean", "median", "std", "min", "max"):
            assert getattr(stats, key) == pytest.approx(theirs[key], abs=1e-6), (tool, key)


def _write_log(path: Path, ref: Trajectory, est: Trajectory) -> None:
    """A rosbag2 (MCAP) log as a Nav2 robot records it: AMCL's pose in `map`, odometry in
    `odom`."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        amcl = w.add_connection("/amcl_pose", "geometry_msgs/msg/PoseWithCovarianceStamped",
                                typestore=store)
        odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        for conn, tr, frame in ((amcl, ref, "map"), (odom, est, "odom")):
            for ts, p, q in zip(tr.t_s, tr.xyz_m, tr.quat_xyzw, strict=True):
                ns = 1_000_000_000 * 100 + round(float(ts) * 1e9)
                header = t["std_msgs/msg/Header"](
                    stamp=t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                    frame_id=frame)
                pose = t["geometry_msgs/msg/Pose"](
                    position=t["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
                    orientation=t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2],
                                                                  w=q[3]))
                cov = t["geometry_msgs/msg/PoseWithCovariance"](pose=pose,
                                                                covariance=np.zeros(36))
                if frame == "map":
                    m = t["geometry_msgs/msg/PoseWithCovarianceStamped"](header=header,
                                                                          pose=cov)
                else:
                    zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
                    m = t["nav_msgs/msg/Odometry"](
                        header=header, child_frame_id="base_link", pose=cov,
                        twist=t["geometry_msgs/msg/TwistWithCovariance"](
                            twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
                            covariance=np.zeros(36)))
                w.write(conn, ns, store.serialize_cdr(m, m.__msgtype__))


def _nav2_case(tmp_path: Path) -> tuple[Path, Path]:
    """The noisy pair as a Nav2-like log with its profile, and as TUM files for evo (stamps as
    the log holds them: ref.txt, est.txt); skips where evo is absent."""
    evo_exe("evo_ape")  # skips, saying how to install it, where evo is absent
    ref, est = _noisy_pair()
    log = tmp_path / "nav2"
    _write_log(log, ref, est)
    profile = tmp_path / "nav2.yaml"
    profile.write_text("name: nav2\npose: {topic: /amcl_pose}\nestimate: {topic: /odom}\n")
    shift = 100.0
    Trajectory(ref.t_s + shift, ref.xyz_m, ref.quat_xyzw).to_tum(tmp_path / "ref.txt")
    Trajectory(est.t_s + shift, est.xyz_m, est.quat_xyzw).to_tum(tmp_path / "est.txt")
    return log, profile


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_score_aligns_a_log_and_warns_when_frames_differ(tmp_path: Path) -> None:
    log, profile = _nav2_case(tmp_path)
    out = tmp_path / "out"
    plain = kartci("score", log, "--profile", profile, "--out", out)
    assert plain.returncode == 0, plain.stderr
    warning = ("warning: nav2: the reference /amcl_pose is in frame 'map' and the estimate "
               "/odom in 'odom', compared without alignment")
    assert warning in " ".join(plain.stderr.split())
    for flag, tool_args in (("se3", ("-a",)), ("sim3", ("-as",)), ("origin", ("--align_origin",))):
        r = kartci("score", log, "--profile", profile, "--out", out, "--align", flag)
        assert r.returncode == 0, r.stderr
        assert "compared without alignment" not in r.stderr
        doc = json.loads((out / "nav2" / "metrics.json").read_text(encoding="utf-8"))
        theirs = evo(tmp_path, "evo_ape", *tool_args)
        assert doc["metrics"]["ape_rmse_m"]["value"] == pytest.approx(theirs["rmse"], abs=1e-6)
        assert doc["metrics"]["ape_max_m"]["value"] == pytest.approx(theirs["max"], abs=1e-6)


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_score_pairs_poses_within_t_max_diff_as_evo_does(tmp_path: Path) -> None:
    """`--t-max-diff` (and a profile's `t_max_diff_s`) is evo's `--t_max_diff`: the same pairs,
    so the same APE at 0.01 s (both defaults) and at 0.002 s, where the estimate's stamps
    (jittered by 2 ms) lose about a third of their pairs."""
    log, profile = _nav2_case(tmp_path)
    seen = []
    for diff, args in ((None, ()), ("0.002", ("--t-max-diff", "0.002"))):
        out = tmp_path / f"out{diff}"
        r = kartci("score", log, "--profile", profile, "--out", out, "--no-html", *args)
        assert r.returncode == 0, r.stderr
        ours = json.loads((out / "nav2" / "metrics.json").read_text(encoding="utf-8"))
        theirs = evo(tmp_path, "evo_ape", *(("--t_max_diff", diff) if diff else ()))
        assert ours["metrics"]["ape_rmse_m"]["value"] == pytest.approx(theirs["rmse"], abs=1e-6)
        seen.append(theirs["rmse"])
    assert seen[0] != seen[1]  # 0.002 s pairs fewer poses than 0.01 s: a different APE
    profile.write_text("name: nav2\npose: {topic: /amcl_pose}\nestimate: {topic: /odom}\n"
                       "t_max_diff_s: 0.002\n")
    r = kartci("score", log, "--profile", profile, "--out", tmp_path / "p", "--no-html")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "p" / "nav2" / "metrics.json").read_text(encoding="utf-8"))
    assert doc["metrics"]["ape_rmse_m"]["value"] == pytest.approx(seen[1], abs=1e-6)
    bad = kartci("score", log, "--profile", profile, "--out", tmp_path / "b", "--t-max-diff",
                 "0")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr


def test_a_profile_names_the_alignment(tmp_path: Path) -> None:
    path = tmp_path / "p.yaml"
    path.write_text("pose: {topic: /a}\nestimate: {topic: /b}\nalign: sim3\nalign_first: 50\n")
    p = load_profile(path, active_project())
    assert (p.align, p.align_first) == (Alignment.SIM3, 50)
    path.write_text("pose: {topic: /a}\nalign: affine\n")
    with pytest.raises(SpecError, match="align"):
        load_profile(path, active_project())
