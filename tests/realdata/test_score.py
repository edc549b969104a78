"""kartci score: the shared fixture logs through profiles, every storage format, exit 2 on logs
without a pose, bad profiles, judging against a baseline and re-scoring from the log."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import ROOT, kartci
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

import kartci as kartci_api
from kartci.errors import LogError, SpecError
from kartci.logs import extract, messages
from kartci.project import current as active_project
from kartci.realdata.profile import load_profile, resolve_profile
from kartci.realdata.score import score_log
from kartci.runner.run import rescore
from kartci.verdict import Status

PROFILES = ROOT / "profiles"


def _metrics(out: Path, name: str) -> dict[str, float]:
    doc = json.loads((out / name / "metrics.json").read_text(encoding="utf-8"))
    return {k: v["value"] for k, v in doc["metrics"].items()}


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_jackal_scored_with_its_profile_and_judged_against_its_baseline(
        bags: Path, tmp_path: Path, baselines: Path) -> None:
    out = tmp_path / "out"
    r = kartci("score", bags / "jackal_imu_odom.bag", "--profile", PROFILES / "jackal.yaml",
               "--out", out, "--baselines", baselines)
    assert r.returncode == 0, r.stderr
    m = _metrics(out, "jackal")
    # 3060 odometry messages over 61 s (fixture README): the duration is the stamps' span
    assert m["duration_s"] == pytest.approx(61.2, abs=0.2)
    assert 50 < m["distance_m"] < 120 and 0 < m["mean_speed_mps"] < m["max_speed_mps"] < 3
    assert (out / "report.html").is_file() and (out / "junit.xml").is_file()
    assert kartci("baseline", "update", out, "jackal", "--baselines", baselines).returncode == 0
    again = score_log(bags / "jackal_imu_odom.bag", PROFILES / "jackal.yaml", out, baselines,
                      active_project())
    assert again.status is Status.PASS
    # a baseline the log no longer meets fails the gate like a simulated run's
    doc = json.loads((baselines / "jackal.json").read_text(encoding="utf-8"))
    doc["metrics"]["distance_m"]["value"] = 200.0
    (baselines / "jackal.json").write_text(json.dumps(doc), encoding="utf-8")
    worse = score_log(bags / "jackal_imu_odom.bag", PROFILES / "jackal.yaml", out, baselines,
                      active_project())
    assert worse.status is Status.REGRESSED
    # the imported run log is a kartci run log: `kartci report` re-scores it from it alone
    (out / "jackal" / "metrics.json").unlink()
    (rescored,) = rescore(out, baselines, active_project())
    assert rescored.status is Status.REGRESSED and _metrics(out, "jackal") == m


def test_no_html_writes_the_same_metrics_and_no_html_report(bags: Path, tmp_path: Path,
                                                             baselines: Path) -> None:
    """With HTML: report.html alone, its figures interactive, and no matplotlib imported (the
    static page's matplotlib doubled the command's start-up)."""
    args = ("score", bags / "jackal_imu_odom.bag", "--profile", PROFILES / "jackal.yaml",
            "--baselines", baselines)
    full, plain = tmp_path / "full", tmp_path / "plain"
    r = kartci(*args, "--out", full, env={"PYTHONPROFILEIMPORTTIME": "1"})
    assert r.returncode == 0, r.stderr
    assert "import time:" in r.stderr and "matplotlib" not in r.stderr
    page = (full / "report.html").read_text(encoding="utf-8")
    assert '<div class="kfigs" data-scenario="jackal">' in page
    assert "report-static.html" not in page and not (full / "report-static.html").exists()
    (full / "report.html").rename(tmp_path / "kept.html")  # --no-html leaves none behind
    r = kartci(*args, "--out", plain, "--no-html")
    assert r.returncode == 0, r.stderr
    assert r.stdout.rstrip().endswith(f"report: {plain / 'summary.md'}  (exit 0)")
    assert sorted(p.name for p in plain.iterdir() if p.name != ".kartci.lock") == [
        "jackal", "junit.xml", "manifest.json", "summary.json", "summary.md"]
    assert (plain / "jackal" / "metrics.json").read_bytes() == (
        full / "jackal" / "metrics.json").read_bytes()
    assert (plain / "jackal" / "run.mcap").read_bytes() == (full / "jackal" / "run.mcap"
                                                            ).read_bytes()


@pytest.mark.parametrize("profile", sorted(PROFILES.glob("*.yaml")), ids=lambda p: p.stem)
def test_every_shipped_profile_matches_its_fixture(bags: Path, profile: Path) -> None:
    logs = {"jackal": "jackal_imu_odom.bag", "turtlebot3": "turtlebot3_gazebo_cmd_odom_scan.bag",
            "luminar_stage": "luminar_points_stage.bag"}
    p, info = resolve_profile(bags / logs[profile.stem], profile, active_project())
    assert info["pose"].count > 0 and p.name == profile.stem


def test_every_storage_format_scores_the_same(bags: Path, tmp_path: Path) -> None:
    """The jackal's odometry as a ROS 1 bag, a bare MCAP file, and rosbag2 folders with MCAP
    and sqlite3 storage: the same metrics from each."""
    src = bags / "jackal_imu_odom.bag"
    topic = "/jackal_velocity_controller/odom"
    bare = tmp_path / "odom.mcap"
    extract(src, [topic], bare)
    store = get_typestore(Stores.ROS2_HUMBLE)
    folders = []
    for plugin in (StoragePlugin.SQLITE3, StoragePlugin.MCAP):
        folder = tmp_path / f"rosbag2_{plugin.name.lower()}"
        with Writer(folder, version=8, storage_plugin=plugin) as w:
            conn = w.add_connection(topic, "nav_msgs/msg/Odometry", typestore=store)
            for _, t_ns, m in messages(bare, [topic]):
                w.write(conn, t_ns, store.serialize_cdr(m, "nav_msgs/msg/Odometry"))
        folders.append(folder)
    results = []
    for i, log in enumerate([src, bare, *folders]):
        out = tmp_path / f"out{i}"
        result = score_log(log, None, out, tmp_path, active_project())
        assert result.error is None, result.error
        results.append(_metrics(out, result.name))
    assert all(r == results[0] for r in results[1:])


@pytest.mark.parametrize("log", ["cmd_vel_twiststamped.mcap", "rosbag2_talker_mcap",
                                 "rosbag2_cdr_test_db3", "ros1_no_messages.bag"])
def test_a_log_without_pose_is_refused(bags: Path, log: str) -> None:
    with pytest.raises(SpecError, match="no pose or odometry topic with messages"):
        resolve_profile(bags / log, None, active_project())


def test_a_log_without_pose_is_one_line_and_exit_2(bags: Path, tmp_path: Path) -> None:
    r = kartci("score", bags / "rosbag2_talker_mcap", "--out", tmp_path / "out",
               "--baselines", tmp_path)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "no pose or odometry topic" in r.stderr


def test_a_profile_naming_a_missing_topic_is_one_line_and_exit_2(bags: Path,
                                                                  tmp_path: Path) -> None:
    profile = tmp_path / "p.yaml"
    profile.write_text("name: p\npose: {topic: /odom}\nimu: {topic: /nope}\n", encoding="utf-8")
    r = kartci("score", bags / "turtlebot3_gazebo_cmd_odom_scan.bag", "-p", profile,
               "--out", tmp_path / "out", "--baselines", tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert "imu topic /nope is not in the log" in r.stderr
    assert not (tmp_path / "out" / "p").exists()


def test_profile_errors_name_the_file_and_key(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("pose: {topic: /odom}\nimu: {topik: /imu}\n", encoding="utf-8")
    with pytest.raises(SpecError, match=r"bad.yaml: imu.topic"):
        load_profile(bad, active_project())


def test_a_pose_of_the_wrong_type_is_refused(bags: Path, tmp_path: Path) -> None:
    profile = tmp_path / "w.yaml"
    profile.write_text("pose: {topic: /scan}\n", encoding="utf-8")
    with pytest.raises(SpecError, match="pose topic /scan is sensor_msgs/msg/LaserScan"):
        resolve_profile(bags / "turtlebot3_gazebo_cmd_odom_scan.bag", profile, active_project())


def test_localization_error_of_an_estimate(bags: Path, tmp_path: Path) -> None:
    """An estimate offset by a known 0.3 m from the reference: APE 0.3 m exactly, RPE 0."""
    from kartci.logs import McapLogWriter

    src = tmp_path / "odom.mcap"
    extract(bags / "jackal_imu_odom.bag", ["/jackal_velocity_controller/odom"], src)
    log = tmp_path / "with_estimate.mcap"
    with McapLogWriter(log) as w:
        for i, (topic, t_ns, m) in enumerate(messages(src)):
            if i == 500:  # 10 s of it
                break
            w.write(topic, m, t_ns)
            m.pose.pose.position.x += 0.3
            w.write("/ekf/odom", m, t_ns)
    profile = tmp_path / "loc.yaml"
    profile.write_text("name: loc\npose: {topic: /jackal_velocity_controller/odom}\n"
                       "estimate: {topic: /ekf/odom}\n", encoding="utf-8")
    out = tmp_path / "out"
    assert score_log(log, profile, out, tmp_path, active_project()).error is None
    m = _metrics(out, "loc")
    assert m["ape_rmse_m"] == pytest.approx(0.3, abs=1e-9)
    assert m["ape_max_m"] == pytest.approx(0.3, abs=1e-9)
    assert m["rpe_1m_rmse_m"] == pytest.approx(0.0, abs=1e-6)


def test_a_run_log_scored_through_a_profile_gets_the_runs_own_track_metrics(
        tmp_path: Path) -> None:
    """A simulated kart run on the hall track into its wall, scored as a foreign log with a
    profile naming the same track and the collision topic: progress, cross-track error, speeds
    and collisions equal the run's own metrics."""
    run = tmp_path / "run"
    kartci_api.run("kart_wall", out=run, baselines=tmp_path)
    profile = tmp_path / "hall.yaml"
    track = ROOT / "sims" / "winti" / "track.csv"
    profile.write_text(f"name: hall\npose: {{topic: /kart0/odom}}\ntrack: {track}\n"
                       "collisions: {topic: /kart0/collision}\n", encoding="utf-8")
    out = tmp_path / "out"
    assert score_log(run / "kart_wall" / "run.mcap", profile, out, tmp_path,
                     active_project()).error is None
    own, scored = _metrics(run, "kart_wall"), _metrics(out, "hall")
    for name in ("progress_m", "cross_track_rms_m", "mean_speed_mps", "max_speed_mps",
                 "laps_completed", "collisions"):
        assert scored[name] == own[name], name
    assert scored["progress_m"] > 3 and scored["collisions"] >= 1



def test_a_pose_in_another_frame_than_the_profile_says_is_refused(bags: Path,
                                                                  tmp_path: Path) -> None:
    profile = tmp_path / "tb.yaml"
    profile.write_text("name: tb\npose: {topic: /odom, frame_id: map}\n", encoding="utf-8")
    with pytest.raises(LogError, match="/odom is in frame 'odom', the profile expects 'map'"):
        score_log(bags / "turtlebot3_gazebo_cmd_odom_scan.bag", profile, tmp_path / "o", tmp_path,
                  active_project())


def test_criteria_of_the_profile_gate_the_log(bags: Path, tmp_path: Path) -> None:
    profile = tmp_path / "fast.yaml"
    profile.write_text("name: fast\npose: {topic: /jackal_velocity_controller/odom}\n"
                       "criteria: {max_speed_mps: {max: 1.0}, duration_s: {min: 60}}\n",
                       encoding="utf-8")
    result = score_log(bags / "jackal_imu_odom.bag", profile, tmp_path / "o", tmp_path,
                       active_project())
    verdict = {c.name: c.ok for c in result.criteria}
    assert verdict == {"max_speed_mps": False, "duration_s": True}  # it reaches 1.99 m/s
    assert result.status is Status.FAILED
