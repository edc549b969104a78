"""`kartci diff`: where two run logs diverge. Real run logs, and copies of them rewritten with
kartci's own log writer with one thing changed, compared through the command as a user runs it."""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import kartci

from kartci.cli import main
from kartci.logs import McapLogWriter, header, msg, open_log, topics, typestore
from kartci.logs.diff import DiffOptions, Ignore, diff_logs
from kartci.logs.types import for_writing
from kartci.logs.wallclock import wall_clock
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import simulate

Change = Callable[[str, int, int, Any], Any]  # (topic, index on topic, log time ns, message)


def diff(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    """`kartci diff ARGS` in this process: exit code, stdout, stderr."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sys, "argv", ["kartci", "diff", *map(str, args)])
        try:
            main()
            code = 0
        except SystemExit as done:
            code = int(done.code or 0)
    out = capsys.readouterr()
    return code, out.out, out.err


def rewrite(src: Path, dst: Path, change: Change) -> None:
    """A copy of a log written by kartci's writer; `change` returns the message to write in
    place of each one (None: leave it out)."""
    seen: Counter[str] = Counter()
    with open_log(src) as log, McapLogWriter(dst, for_writing(log.typestore)) as out:
        for topic, t_ns, m in log.messages():
            new = change(topic, seen[topic], t_ns, m)
            seen[topic] += 1
            if new is not None:
                out.write(topic, new, t_ns)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two run folders of one MPCC scenario (1 s): identical but for the solve times."""
    root = tmp_path_factory.mktemp("runs")
    for name in ("a", "b"):
        simulate(load_scenario("mpcc_lap", ["duration_s=1"],
                               project=active_project()), root / name / "run.mcap")
    return root / "a", root / "b"


def test_two_runs_of_one_scenario_are_identical(capsys: pytest.CaptureFixture[str],
                                                runs: tuple[Path, Path]) -> None:
    code, out, err = diff(capsys, *runs)
    assert code == 0, out + err
    assert out.startswith("identical: ") and out.count("\n") == 1
    n = sum(i.count for i in topics(runs[0] / "run.mcap"))
    assert f"identical: {n} messages compared on 15 topics" in out
    assert "not compared (wall clock): solve_ms on /kart0/mpcc/stats" in out


def test_wall_clock_fields_differ_and_are_compared_on_request(
        capsys: pytest.CaptureFixture[str], runs: tuple[Path, Path]) -> None:
    code, out, _ = diff(capsys, runs[0] / "run.mcap", runs[1], "--wall-clock")
    assert code == 1
    assert "first difference: /kart0/mpcc/stats message 0 (counted from 0), t = 0 s" in out
    assert "  solve_ms  A " in out
    assert "not compared" not in out


def test_the_one_changed_field_is_reported_with_both_values(
        capsys: pytest.CaptureFixture[str], runs: tuple[Path, Path], tmp_path: Path) -> None:
    before: dict[str, Any] = {}

    def nudge(topic: str, index: int, t_ns: int, m: Any) -> Any:
        if topic == "/kart0/odom" and index == 30:
            m = copy.deepcopy(m)
            x = m.pose.pose.position.x
            m.pose.pose.position.x = math.nextafter(x, math.inf)  # the last bit
            before.update(x=x, new=m.pose.pose.position.x, t_ns=t_ns)
        return m

    changed = tmp_path / "changed.mcap"
    rewrite(runs[0] / "run.mcap", changed, nudge)
    code, out, _ = diff(capsys, runs[0], changed)
    assert code == 1
    lines = out.splitlines()
    t = f"{before['t_ns'] / 1e9:.9f}".rstrip("0").rstrip(".")
    assert lines[2] == (f"first difference: /kart0/odom message 30 (counted from 0), t = {t} s, "
                        "nav_msgs/msg/Odometry")
    assert lines[3] == (f"  pose.pose.position.x  A {before['x']!r}  B {before['new']!r}  "
                        f"B-A {before['new'] - before['x']!r}")
    assert lines[4].startswith("not compared (wall clock)")
    assert lines[-1].startswith("logs differ (")
    # the same through the library; the rest of the copy is the original byte for byte
    first = diff_logs(runs[0] / "run.mcap", changed).first
    assert first is not None and len(first.fields) == 1 and first.more_fields == 0
    assert diff_logs(runs[0] / "run.mcap", changed,
                     DiffOptions(ignore=(Ignore("/kart0/odom", "pose.pose.position.x"),))
                     ).identical
    assert diff_logs(runs[0] / "run.mcap", changed, DiffOptions(tolerance=1e-12)).identical


def test_a_log_that_ends_earlier(capsys: pytest.CaptureFixture[str], runs: tuple[Path, Path],
                                 tmp_path: Path) -> None:
    short = tmp_path / "short.mcap"
    rewrite(runs[0] / "run.mcap", short, lambda _, i, t_ns, m: m if t_ns < 500_000_000 else None)
    code, out, _ = diff(capsys, runs[1], short)
    assert code == 1
    assert "topic /kart0/odom: different message counts, A 51, B 25" in out
    assert "first difference: /kart0/odom message 25 (counted from 0), t = 0.5 s" in out
    assert "  only in A: B has no message 25 on /kart0/odom (A has 51, B 25)" in out


def test_a_topic_in_one_log_only_and_a_topic_of_another_type(
        capsys: pytest.CaptureFixture[str], runs: tuple[Path, Path], tmp_path: Path) -> None:
    def drop_imu_retype_cmd(topic: str, index: int, t_ns: int, m: Any) -> Any:
        if topic == "/kart0/imu":
            return None
        return msg("std_msgs/msg/String", data="x") if topic == "/kart0/cmd" else m

    other = tmp_path / "other.mcap"
    rewrite(runs[0] / "run.mcap", other, drop_imu_retype_cmd)
    code, out, _ = diff(capsys, runs[1], other)
    assert code == 1
    assert ("topic /kart0/cmd: type kartci_msgs/msg/KartCommand in A, std_msgs/msg/String in B "
            "(not compared)") in out
    assert "topic /kart0/imu: only in A (sensor_msgs/msg/Imu, 101 messages)" in out
    assert "no message differs on the 13 topics both logs have" in out
    code, out, _ = diff(capsys, runs[1], other, "--ignore", "/kart0/imu", "--ignore", "*/cmd")
    assert code == 0, out
    assert "not compared (--ignore): /kart0/cmd, /kart0/imu" in out


def _pose(x: float) -> Any:
    return msg("geometry_msgs/msg/Pose",
               position=msg("geometry_msgs/msg/Point", x=x, y=0.0, z=0.0),
               orientation=msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0))


def _odometry(path: Path, values: list[tuple[str, int, float]]) -> None:
    """A small log: one Odometry per (topic, log time ns, x)."""
    zero = msg("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=0.0)
    twist = msg("geometry_msgs/msg/TwistWithCovariance", covariance=np.zeros(36),
                twist=msg("geometry_msgs/msg/Twist", linear=zero, angular=zero))
    with McapLogWriter(path) as out:
        for topic, t_ns, x in values:
            pose = msg("geometry_msgs/msg/PoseWithCovariance", pose=_pose(x),
                       covariance=np.zeros(36))
            out.write(topic, msg("nav_msgs/msg/Odometry", header=header(t_ns, "map"),
                                 child_frame_id="base_link", pose=pose, twist=twist), t_ns)


def test_floats_are_compared_bitwise_with_nan_equal_to_nan(tmp_path: Path) -> None:
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    _odometry(a, [("/o", 1, math.nan), ("/o", 2, 0.0)])
    _odometry(b, [("/o", 1, -math.nan), ("/o", 2, -0.0)])
    first = diff_logs(a, b).first
    assert first is not None and first.index == 1
    assert [(f.path, f.a, f.b) for f in first.fields] == [("pose.pose.position.x", 0.0, -0.0)]
    assert diff_logs(a, b, DiffOptions(tolerance=1e-9)).identical


def test_the_first_difference_in_log_time_across_topics(tmp_path: Path) -> None:
    """Messages pair by index on their topic: /x's second message is late in B (log time 2.5
    s), which parts the logs at 2 s, before /y's changed value at 2.2 s."""
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    s = 1_000_000_000
    _odometry(a, [("/x", 1 * s, 1.0), ("/x", 2 * s, 2.0), ("/y", 2_200_000_000, 1.0),
                  ("/x", 3 * s, 3.0)])
    _odometry(b, [("/x", 1 * s, 1.0), ("/y", 2_200_000_000, 9.0), ("/x", 2_500_000_000, 2.0),
                  ("/x", 3 * s, 3.0)])
    first = diff_logs(a, b).first
    assert first is not None
    assert (first.topic, first.index, first.t_a_ns, first.t_b_ns, first.t_ns) == (
        "/x", 1, 2 * s, 2_500_000_000, 2 * s)
    first = diff_logs(b, a, DiffOptions(ignore=(Ignore("/x"),))).first
    assert first is not None and (first.topic, first.t_ns) == ("/y", 2_200_000_000)


def test_the_printed_fields_are_capped(capsys: pytest.CaptureFixture[str],
                                       tmp_path: Path) -> None:
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    for path, scale in ((a, 1.0), (b, 2.0)):
        with McapLogWriter(path) as w:
            poses = [msg("geometry_msgs/msg/PoseStamped", header=header(0, "map"),
                         pose=_pose(i * scale)) for i in range(1, 8)]
            w.write("/path", msg("nav_msgs/msg/Path", header=header(0, "map"), poses=poses), 0)
    code, out, _ = diff(capsys, a, b, "--fields", "3")
    assert code == 1
    assert "  poses[0].pose.position.x  A 1.0  B 2.0  B-A 1.0" in out
    assert "  ... and 4 more differing fields (--fields N shows more)" in out


def _bad_inputs(tmp: Path) -> dict[str, list[str | Path]]:
    junk = tmp / "notes.mcap"
    junk.write_text("SECRET-CONTENT line one\nline two\n")
    (tmp / "empty_folder").mkdir()
    return {"missing file": [tmp / "nope.mcap", junk],
            "not an MCAP": [junk, junk],
            "folder without run.mcap": [tmp / "empty_folder", junk],
            "bad --ignore": [junk, junk, "--ignore", ":field"],
            "negative tolerance": [junk, junk, "--tolerance", "-1"]}


@pytest.mark.parametrize("case", ["missing file", "not an MCAP", "folder without run.mcap",
                                  "bad --ignore", "negative tolerance"])
def test_bad_input_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                          case: str) -> None:
    code, out, err = diff(capsys, *_bad_inputs(tmp_path)[case])
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("kartci: error: "), err
    assert "Traceback" not in err and "SECRET" not in err


def test_wall_clock_fields_are_fields_of_their_types() -> None:
    for msgtype, fields in wall_clock().items():
        names = [f[0] for f in typestore().get_msgdef(msgtype).fields]
        assert set(fields) <= set(names), msgtype


def _simd_levels() -> tuple[list[str], list[str]]:
    """numpy's baseline and the dispatch levels above it that this CPU runs, as a process with
    neither NPY_ENABLE_CPU_FEATURES nor NPY_DISABLE_CPU_FEATURES sees them."""
    code = ("import numpy._core._multiarray_umath as m; "
            "print(','.join(m.__cpu_baseline__)); "
            "print(','.join(n for n in m.__cpu_dispatch__ if m.__cpu_features__.get(n)))")
    env = {k: v for k, v in os.environ.items() if not k.startswith("NPY_")}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       timeout=60)
    if p.returncode != 0:
        pytest.skip(f"numpy has no numpy._core SIMD dispatch tables (numpy 2 has): {p.stderr}")
    baseline, active = p.stdout.splitlines()
    return baseline.split(","), [n for n in active.split(",") if n]


# numpy's dispatch levels with float64 transcendental loops of their own (an X86_V3-only CPU,
# such as an AVX2 EPYC, computes this run's bits exactly as the baseline does: measured)
_FLOAT64_LEVELS = ("X86_V4", "AVX512_SKX", "AVX512F", "AVX512_ICL", "AVX512_SPR")


@pytest.mark.long(reason="runs at two SIMD levels")
def test_runs_at_two_numpy_simd_levels_are_told_apart(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """The laptop-against-CI case: one run restricted to numpy's baseline kernels, one with
    every level this CPU has (AVX-512 here); the tool names where they part."""
    baseline, above = _simd_levels()
    if "X86_V2" not in baseline:
        pytest.skip(f"numpy's baseline is {baseline}, not X86_V2 (not x86-64, or an old numpy)")
    wide = [level for level in above if level in _FLOAT64_LEVELS]
    if not wide:
        pytest.skip(f"this CPU's numpy levels above X86_V2 ({', '.join(above) or 'none'}) have no "
                    "float64 exp/log/tan/arctan kernels of their own (numpy's are AVX-512: "
                    "X86_V4, AVX512_SKX): both runs compute the same bits")
    base_env = {k: v for k, v in os.environ.items()
                if k not in ("NPY_ENABLE_CPU_FEATURES", "NPY_DISABLE_CPU_FEATURES")}
    base_env["KARTCI_SIMD"] = "native"  # keep numpy's own dispatch when kartci pins one
    envs = {"v2": {**base_env, "NPY_ENABLE_CPU_FEATURES": "X86_V2"}, "all": base_env}
    cmd = [sys.executable, "-m", "kartci.cli", "run", "mpcc_lap", "--set", "duration_s=1"]
    procs = {name: subprocess.Popen([*cmd, "--out", str(tmp_path / name)], env=env,
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
             for name, env in envs.items()}
    for name, proc in procs.items():
        text, _ = proc.communicate(timeout=300)
        assert proc.returncode in (0, 1), f"{name}: {text}"  # 1: a 2 s run misses the baseline
    p = kartci("diff", tmp_path / "v2", tmp_path / "all")  # as a user runs it
    assert p.returncode == 1, p.stdout + p.stderr
    assert "\nfirst difference: " in p.stdout and p.stderr == ""
    print(f"levels above baseline: {above}\n{p.stdout}")
