"""`kartci score` against `evo_ape` on the same file, side by side: wall and CPU time (user +
system) of each command as a user runs it (a fresh process, start-up included), the commands
interleaved round by round, median of repeats, on a Nav2-like rosbag2 (MCAP) log: AMCL's pose
(`map`) at 20 Hz and wheel odometry (`odom`) at 50 Hz, SE(3)-aligned (`--align se3` / `-a`).
`kartci score` runs as it comes (run log + HTML reports) and with `--no-html`, started as the
`kartci` script starts it (`python -m kartci`). Both APE RMSEs
are printed too: they must agree. With `--fixtures`, also on the shared fixture logs
(../shared/fixtures/bags: the Jackal's and the TurtleBot3's ROS 1 bags through their shipped
profiles in profiles/; neither holds a second trajectory, so kartci scores the odometry alone,
no APE, and evo_ape reads the odometry as reference and estimate, an APE of 0). Asserts
nothing. CPU time is the steadier figure on a
shared machine: wall time there includes waiting for a core. kartci's modules are byte-compiled
first, as an installed kartci's (and evo's) are: a checkout run with PYTHONDONTWRITEBYTECODE
set would compile them on every run (about 0.3 s; `--source` measures that).

evo is GPL and never a kartci dependency: its CLI runs from its own venv (KARTCI_EVO=DIR/bin,
else .venv-evo/bin, else /tmp/venv-evo/bin).

    .venv/bin/python benchmarks/bench_score_evo.py [--minutes 10] [--repeats 3] [--json OUT]
        [--source] [--fixtures]
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

from kartci.bench import Better, Record

ROOT = Path(__file__).resolve().parents[1]
PROFILE = "name: nav2\npose: {topic: /amcl_pose}\nestimate: {topic: /odom}\n"
FIXTURES = ROOT.parent / "shared" / "fixtures" / "bags"
# fixture log -> (its profile in profiles/, its odometry topic)
FIXTURE_LOGS = {"jackal_imu_odom.bag": ("jackal", "/jackal_velocity_controller/odom"),
                "turtlebot3_gazebo_cmd_odom_scan.bag": ("turtlebot3", "/odom")}


def evo_bin() -> Path:
    """The folder of evo's scripts."""
    for folder in (os.environ.get("KARTCI_EVO", ""), ROOT / ".venv-evo" / "bin",
                   "/tmp/venv-evo/bin"):
        if folder and (Path(folder) / "evo_ape").is_file():
            return Path(folder)
    sys.exit("evo_ape not found: python3 -m venv .venv-evo && .venv-evo/bin/python -m pip "
             "install evo")


def write_log(path: Path, minutes: float) -> int:
    """A robot driving loops for `minutes`: odometry drifting in `odom`, AMCL noisy in `map`
    (odom is map turned 0.4 rad and shifted); returns the message count."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    rng = np.random.default_rng(0)
    count = 0

    def pose(ts: float, p: np.ndarray, yaw: float) -> tuple[int, tuple[Any, Any]]:
        ns = 10**9 * 1000 + round(ts * 1e9)
        q = Rotation.from_euler("z", yaw).as_quat()
        hdr = (t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
               t["geometry_msgs/msg/PoseWithCovariance"](
                   pose=t["geometry_msgs/msg/Pose"](
                       position=t["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=0.0),
                       orientation=t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2],
                                                                     w=q[3])),
                   covariance=np.zeros(36)))
        return ns, hdr

    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        amcl = w.add_connection("/amcl_pose", "geometry_msgs/msg/PoseWithCovarianceStamped",
                                typestore=store)
        odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        twist = t["geometry_msgs/msg/TwistWithCovariance"](
            twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
            covariance=np.zeros(36))
        turn = Rotation.from_euler("z", 0.4)
        for k in range(round(minutes * 60 * 50)):  # 50 Hz; AMCL every 2.5th tick (20 Hz)
            ts = k / 50
            truth = np.array([8 * np.cos(0.05 * ts), 5 * np.sin(0.1 * ts), 0.0])
            yaw = 0.05 * ts
            drift = np.array([0.002 * ts, -0.001 * ts, 0.0])
            ns, (stamp, cov) = pose(ts, turn.apply(truth) + drift, yaw + 0.4)
            header = t["std_msgs/msg/Header"](stamp=stamp, frame_id="odom")
            m = t["nav_msgs/msg/Odometry"](header=header, child_frame_id="base_link",
                                           pose=cov, twist=twist)
            w.write(odom, ns, store.serialize_cdr(m, "nav_msgs/msg/Odometry"))
            count += 1
            if k % 5 in (0, 2):
                ns, (stamp, cov) = pose(ts, truth + rng.normal(0, 0.05, 3) * [1, 1, 0], yaw)
                header = t["std_msgs/msg/Header"](stamp=stamp, frame_id="map")
                a = t["geometry_msgs/msg/PoseWithCovarianceStamped"](header=header, pose=cov)
                w.write(amcl, ns, store.serialize_cdr(
                    a, "geometry_msgs/msg/PoseWithCovarianceStamped"))
                count += 1
    return count


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU (user + system) seconds of one command, which must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{proc.stdout}{proc.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def compare(label: str, name: str, log: Path, profile: str, evo_ape: list[str], folder: Path,
            repeats: int, record: Record, align: bool = True) -> None:
    """kartci score (with and without HTML) and evo_ape on one log, interleaved round by round;
    medians printed and recorded under `label`."""
    work = folder / name
    work.mkdir()
    (work / "profile.yaml").write_text(profile, encoding="utf-8")
    (work / "bl").mkdir()
    env = {**os.environ, "HOME": str(work), "MPLBACKEND": "Agg"}  # evo's ~/.evo
    # `python -m kartci` is what the `kartci` script runs; `-m kartci.cli` would import the
    # whole CLI (~0.4 s CPU) before the pinned re-exec imports it again
    kartci = [sys.executable, "-m", "kartci", "score", str(log), "--profile",
              str(work / "profile.yaml"), *(["--align", "se3"] if align else []),
              "--baselines", str(work / "bl")]
    runs: dict[str, Callable[[int], list[str]]] = {
        "kartci score": lambda i: [*kartci, "--out", str(work / f"out{i}")],
        "kartci score --no-html": lambda i: [*kartci, "--no-html", "--out",
                                             str(work / f"plain{i}")],
        "evo_ape": lambda i: [*evo_ape, "--save_results", str(work / f"evo{i}.zip")]}
    print(f"{label}; s per command (fresh process)")
    samples: dict[str, list[tuple[float, float]]] = {n: [] for n in runs}
    for i in range(repeats):  # interleaved: a load change hits every command alike
        for n, make in runs.items():
            samples[n].append(timed(make(i), env))
    medians = {}
    for n, got in samples.items():
        for k, what in enumerate(("wall", "cpu")):
            values = [g[k] for g in got]
            medians[n, what] = statistics.median(values)
            record.add(f"{name}: {n} {what}", "s", values, Better.LOWER)
            print(f"  {n:24s} {what:4s} median {medians[n, what]:6.2f}  "
                  f"({', '.join(f'{v:.2f}' for v in values)})")
    with zipfile.ZipFile(work / "evo0.zip") as z:
        evo_rmse = json.loads(z.read("stats.json"))["rmse"]
    doc = json.loads((work / "out0" / name / "metrics.json").read_text())
    ours = doc["metrics"].get("ape_rmse_m", {}).get("value")
    print(f"  APE RMSE: evo {evo_rmse:.9f} m, " + (
        "kartci none (no estimate)" if ours is None else
        f"kartci {ours:.9f} m (difference {abs(ours - evo_rmse):.2e})"))
    for n in ("kartci score", "kartci score --no-html"):
        ratio = {w: medians[n, w] / medians["evo_ape", w] for w in ("wall", "cpu")}
        print(f"  {n} / evo_ape: wall {ratio['wall']:.2f}x, cpu {ratio['cpu']:.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--minutes", type=float, default=10.0, help="log length, min")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    parser.add_argument("--source", action="store_true",
                        help="do not byte-compile kartci first (as a checkout without .pyc)")
    parser.add_argument("--fixtures", action="store_true",
                        help="also the shared fixture logs (../shared/fixtures/bags)")
    args = parser.parse_args()
    evo = evo_bin()
    if not args.source:
        compileall.compile_dir(ROOT / "kartci", quiet=1)
    record = Record("bench_score_evo")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        log = folder / "nav2.log"
        n = write_log(log, args.minutes)
        compare(f"{args.minutes:g} min Nav2-like log, {n} messages", "nav2", log, PROFILE,
                [str(evo / "evo_ape"), "bag2", str(log), "/amcl_pose", "/odom", "-a",
                 "--no_warnings"], folder, args.repeats, record)
        for bag, (name, topic) in FIXTURE_LOGS.items() if args.fixtures else ():
            profile = (ROOT / "profiles" / f"{name}.yaml").read_text(encoding="utf-8")
            compare(f"fixture {bag} (evo_ape: {topic} against itself)", name, FIXTURES / bag,
                    profile, [str(evo / "evo_ape"), "bag", str(FIXTURES / bag), topic, topic,
                              "-a", "--no_warnings"], folder, args.repeats, record,
                    align=False)
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
