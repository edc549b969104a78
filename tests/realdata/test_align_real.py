"""Aligned APE on a real robot's log, against evo's command line: a Jarvis AGV (INESC TEC CROB
lab, ../shared/fixtures/bags/jarvis_circular_path_fast.bag, 25 s, 11 m) whose wheel odometry
is on /tf (odom -> base_footprint) and whose map-frame localization, a reflector-beacon laser
positioning system, is /pose_ground_truth (PoseStamped in `map`). The two are in different
frames, as odometry and AMCL are on a Nav2 robot: without alignment kartci warns (APE 3.52 m),
with SE(3) / Sim(3) alignment it equals `evo_ape -a` / `-as` (0.0231 m / 0.0176 m).

evo reads a /tf chain only with ROS's tf2_py, which its pip environment lacks, so evo gets the
log as TUM files: the reference as recorded (header stamps) and the odometry looked up at those
stamps as tf2 does (translation linear, rotation slerp between the two neighbouring transforms,
none outside their span); association, alignment and the statistics are evo's own. (evo 1.38's
bag reader would look the chain up on its own 10 Hz grid, `tf_cache_lookup_frequency`, and pair
only stamps within 10 ms of the reference's: 0.0235 m with -a, from other samples.)"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import evo, evo_exe, kartci
from rosbags.highlevel import AnyReader
from scipy.spatial.transform import Rotation, Slerp

BAG = "jarvis_circular_path_fast.bag"
SOURCE = ("carlosmccosta/dynamic_robot_localization_tests @ 4edbaac, "
          "datasets/crob_lab/jarvis/jarvis_circular_path_fast.bag (BSD-3-Clause)")
PROFILE = "name: jarvis\npose: {topic: /pose_ground_truth}\n" \
          "estimate: {topic: /tf, parent: odom, child: base_footprint}\n"
WARNING = ("warning: jarvis: the reference /pose_ground_truth is in frame 'map' and the "
           "estimate /tf in 'odom', compared without alignment")


# kartci score's --align, evo_ape's flags: none (the default) warns, se3 is -a, sim3 is -as
CASES: list[tuple[tuple[str, ...], tuple[str, ...]]] = [
    ((), ()), (("--align", "se3"), ("-a",)), (("--align", "sim3"), ("-as",))]


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 10**9 + int(stamp.nanosec)


def _read(log: Path) -> tuple[np.ndarray, np.ndarray]:
    """Rows (t_ns, x, y, z, qx, qy, qz, qw) of /pose_ground_truth and of odom -> base_footprint,
    each sorted by stamp (the transforms one per stamp)."""
    ref, odom = [], []
    with AnyReader([log]) as reader:
        for conn, _, raw in reader.messages():
            if conn.topic == "/pose_ground_truth":
                m: Any = reader.deserialize(raw, conn.msgtype)
                p, q = m.pose.position, m.pose.orientation
                ref.append((_stamp_ns(m.header.stamp), p.x, p.y, p.z, q.x, q.y, q.z, q.w))
            elif conn.topic == "/tf":
                tf_msg: Any = reader.deserialize(raw, conn.msgtype)
                for tr in tf_msg.transforms:
                    if (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/")) == (
                            "odom", "base_footprint"):
                        p, q = tr.transform.translation, tr.transform.rotation
                        odom.append((_stamp_ns(tr.header.stamp), p.x, p.y, p.z,
                                     q.x, q.y, q.z, q.w))
    tf = np.array(sorted(odom))
    return np.array(sorted(ref)), tf[np.unique(tf[:, 0], return_index=True)[1]]


def _write_tum(log: Path, folder: Path) -> int:
    """ref.txt and est.txt for evo: the reference inside the odometry's span, the odometry at
    its stamps. Returns the number of poses."""
    ref, tf = _read(log)
    ref = ref[(ref[:, 0] >= tf[0, 0]) & (ref[:, 0] <= tf[-1, 0])]
    knots, at = (tf[:, 0] - tf[0, 0]) * 1e-9, (ref[:, 0] - tf[0, 0]) * 1e-9
    xyz = np.column_stack([np.interp(at, knots, tf[:, k]) for k in (1, 2, 3)])
    quat = Slerp(knots, Rotation.from_quat(tf[:, 4:]))(at).as_quat()
    fmt = "%.9f" + " %.17g" * 7
    np.savetxt(folder / "ref.txt", np.column_stack([ref[:, 0] * 1e-9, ref[:, 1:]]), fmt=fmt)
    np.savetxt(folder / "est.txt", np.column_stack([ref[:, 0] * 1e-9, xyz, quat]), fmt=fmt)
    return len(ref)


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_a_real_robots_odometry_against_its_map_localization_equals_evo(
        bags: Path, tmp_path: Path) -> None:
    evo_exe("evo_ape")  # skips, saying how to install it, where evo is absent
    log = bags / BAG
    if not log.is_file():
        pytest.skip(f"{log} not found: it comes from {SOURCE}")
    profile = tmp_path / "jarvis.yaml"
    profile.write_text(PROFILE, encoding="utf-8")
    assert _write_tum(log, tmp_path) == 204  # every localization pose of the 25 s
    out = tmp_path / "out"
    for align, evo_args in CASES:
        r = kartci("score", log, "--profile", profile, "--out", out, "--no-html", *align)
        assert r.returncode == 0, r.stderr
        assert (WARNING in " ".join(r.stderr.split())) == (not align), r.stderr
        ours = json.loads((out / "jarvis" / "metrics.json").read_text(encoding="utf-8"))
        theirs = evo(tmp_path, "evo_ape", *evo_args)
        for key in ("rmse", "mean", "max"):
            assert ours["metrics"][f"ape_{key}_m"]["value"] == pytest.approx(
                theirs[key], abs=1e-6), (align, key)
