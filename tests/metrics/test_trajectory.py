"""kartci's APE / RPE equal evo's, run through evo's own command line on the same TUM files."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

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

BIN = Path(sys.executable).parent


def _pair(seed: int = 0) -> tuple[Trajectory, Trajectory]:
    """A 3D reference at 20 Hz and a noisy, drifting estimate at 10 Hz with jittered stamps,
    so that association, path-based pairs and rotations all matter."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 30.0, 0.05)
    ref = Trajectory(t, np.column_stack([5 * np.cos(0.2 * t), 5 * np.sin(0.2 * t),
                                         0.1 * np.sin(t)]),
                     Rotation.from_euler("zyx", np.column_stack([0.3 * t, 0.05 * np.sin(t),
                                                                 0.02 * t])).as_quat())
    te = t[::2] + rng.normal(0.0, 0.002, len(t[::2]))
    noise = Rotation.from_rotvec(rng.normal(0.0, 0.02, (len(te), 3)))
    est = Trajectory(te, np.column_stack([5 * np.cos(0.2 * te) + rng.normal(0, 0.05, len(te)),
                                          5 * np.sin(0.2 * te), 0.01 * te]),
                     (Rotation.from_euler("zyx", np.column_stack(
                         [0.3 * te, 0.05 * np.sin(te), 0.02 * te])) * noise).as_quat())
    return ref, est


def _evo(tmp: Path, tool: str, *args: str) -> dict[str, float]:
    """Run evo_ape / evo_rpe on tmp/ref.txt and tmp/est.txt; its saved statistics."""
    exe = BIN / tool
    if not exe.exists() and shutil.which(tool) is None:
        pytest.skip(f"{tool} not installed (it comes with the dev extras: pip install -e '.[dev]')")
    out = tmp / "res.zip"
    out.unlink(missing_ok=True)
    env = {**os.environ, "HOME": str(tmp), "MPLBACKEND": "Agg"}  # evo keeps settings in ~/.evo
    proc = subprocess.run([str(exe if exe.exists() else tool), "tum", "ref.txt", "est.txt", *args,
                           "--save_results", str(out), "--no_warnings"],
                          cwd=tmp, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    with zipfile.ZipFile(out) as z:
        stats: dict[str, float] = json.loads(z.read("stats.json"))
    return stats


def _assert_equal(ours: ErrorStats, evo: dict[str, float]) -> None:
    for key in ("rmse", "mean", "median", "std", "min", "max"):
        assert getattr(ours, key) == pytest.approx(evo[key], abs=1e-9), key


@pytest.mark.parametrize(("tool", "args", "ours"), [
    ("evo_ape", (), lambda r, e: ape(r, e)),
    ("evo_ape", ("-r", "angle_deg"), lambda r, e: ape(r, e, Relation.ROTATION_DEG)),
    ("evo_rpe", ("-d", "1", "-u", "m"), lambda r, e: rpe(r, e, 1.0)),
    ("evo_rpe", ("-d", "1", "-u", "m", "-r", "angle_deg"),
     lambda r, e: rpe(r, e, 1.0, relation=Relation.ROTATION_DEG)),
    ("evo_rpe", ("-d", "7", "-u", "f"), lambda r, e: rpe(r, e, 7, DeltaUnit.FRAMES)),
    ("evo_rpe", ("-d", "3", "-u", "f", "--all_pairs"),
     lambda r, e: rpe(r, e, 3, DeltaUnit.FRAMES, all_pairs=True)),
], ids=["ape-trans", "ape-angle", "rpe-1m", "rpe-1m-angle", "rpe-7f", "rpe-3f-all"])
def test_equals_evo(tmp_path: Path, tool: str, args: tuple[str, ...], ours) -> None:  # type: ignore[no-untyped-def]
    ref, est = _pair()
    ref.to_tum(tmp_path / "ref.txt")
    est.to_tum(tmp_path / "est.txt")
    # the files are what evo reads: compute from them too, so both see the same numbers
    r, e = associate(Trajectory.from_tum(tmp_path / "ref.txt"),
                     Trajectory.from_tum(tmp_path / "est.txt"))
    assert len(r) == len(est)  # every estimate stamp is within 10 ms of a reference stamp
    _assert_equal(ours(r, e), _evo(tmp_path, tool, *args))


def test_seconds_delta_is_frames_at_a_fixed_rate() -> None:
    """At 20 Hz, RPE per 1 s is RPE per 20 frames (the float sum of 0.05 s falls short of 1 s
    by a bit; it still counts)."""
    ref, _ = _pair()
    rng = np.random.default_rng(3)
    est = Trajectory(ref.t_s, ref.xyz_m + rng.normal(0, 0.03, ref.xyz_m.shape), ref.quat_xyzw)
    assert rpe(ref, est, 1.0, DeltaUnit.SECONDS) == rpe(ref, est, 20, DeltaUnit.FRAMES)


def test_identical_trajectories_have_zero_error() -> None:
    ref, _ = _pair()
    assert ape(ref, ref).max == 0.0
    assert ape(ref, ref, Relation.ROTATION_DEG).max == pytest.approx(0.0, abs=1e-6)
    assert rpe(ref, ref, 1.0).max == pytest.approx(0.0, abs=1e-12)


def test_a_constant_offset_is_ape_not_rpe() -> None:
    """A 0.3 m shift of the whole estimate: APE 0.3 m everywhere, RPE zero."""
    ref, _ = _pair()
    est = Trajectory(ref.t_s, ref.xyz_m + np.array([0.3, 0.0, 0.0]), ref.quat_xyzw)
    assert ape(ref, est).rmse == pytest.approx(0.3, abs=1e-12)
    assert rpe(ref, est, 1.0).max == pytest.approx(0.0, abs=1e-12)


def test_tum_round_trip_is_exact(tmp_path: Path) -> None:
    ref, _ = _pair()
    ref.to_tum(tmp_path / "t.txt")
    back = Trajectory.from_tum(tmp_path / "t.txt")
    assert np.array_equal(back.t_s, ref.t_s)
    assert np.array_equal(back.xyz_m, ref.xyz_m)
    assert np.array_equal(back.quat_xyzw, ref.quat_xyzw)


def test_bad_input_is_one_clear_error(tmp_path: Path) -> None:
    ref, est = _pair()
    (tmp_path / "bad.txt").write_text("0 1 2 3\n")
    with pytest.raises(TrajectoryError, match="8 columns"):
        Trajectory.from_tum(tmp_path / "bad.txt")
    with pytest.raises(TrajectoryError, match="no stamps"):
        associate(ref, est, offset_s=100.0)
    with pytest.raises(TrajectoryError, match="no pose pairs"):
        rpe(ref, ref, 1e6)
