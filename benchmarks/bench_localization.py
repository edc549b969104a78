"""Localization and obstacle detection per VLP-16 scan on one core, and localization_lap's
real-time factor. Scans are simulated along the hall's track at 6 m/s and 0.5 rad/s with motion
distortion, 3 cm range noise and 5% dropout; each is deskewed and registered to the shipped map
from a guess 0.2 m / 1 degree off, as the node does between two scans. Prints medians and p95
(and the registration error, which is what chose the method); asserts nothing. Per-scan
figures are CPU time of this process (time.process_time: one thread, so one core's worth),
which a shared machine's load disturbs far less than wall-clock time.

    .venv/bin/python benchmarks/bench_localization.py [--scans 40] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from kartci.bench import Better, Record
from kartci.localization.deskew import deskew
from kartci.localization.registration import MapMatcher, pose_matrix
from kartci.perception.clusters import MapMask, clusters, obstacle_points
from kartci.pointcloud import read_ply
from kartci.project import current as active_project
from kartci.robots.gokart.noise import distorted_scan
from kartci.scenario import load_scenario
from kartci.scenario.load import load_world
from kartci.sim import lidar, simulate
from kartci.sim.body import BodyState
from kartci.worlds.hall import HallWorld
from kartci.worlds.hall.world import blocks
from kartci.worlds.track import load_track

V, W, H = 6.0, 0.5, 1.28
VLP16 = lidar.MODELS["vlp16"]


def hall_map() -> Path:
    """The hall's point-cloud map (`kartci map winti/hall`)."""
    return active_project().world_file("winti/hall_map.ply")


def scans(n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(points in the sensor frame, true x y yaw) along the track, obstacles included."""
    world, _ = load_world("winti/hall", active_project())
    assert isinstance(world, HallWorld)
    spec = load_scenario("perception_obstacles", project=active_project()).world
    assert isinstance(spec, HallWorld)
    bl = blocks(spec)
    track = load_track(Path(world.track))
    az = VLP16.azimuths(10.0)
    rng = np.random.default_rng(0)
    out = []
    for s in np.linspace(0.0, track.length_m, n, endpoint=False):
        x, y, yaw = track.pose_at(float(s))
        st = BodyState((x, y, 0.13), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)),
                       (V, 0.0, 0.0), (0.0, 0.0, W))

        def cast(a: np.ndarray, p: np.ndarray, h: float | np.ndarray) -> np.ndarray:
            return lidar.scan_fast(VLP16, a, p, h, bl, spec.wall_height_m, 100.0)

        r = distorted_scan(cast, az, st, np.array([x, y, H]), 10.0)
        r = r + 0.03 * rng.standard_normal(r.shape)
        r[rng.random(r.shape) < 0.05] = np.inf
        pts = lidar.to_points(VLP16, az, r)
        out.append((np.column_stack([pts["x"], pts["y"], pts["z"]]).astype(float),
                    np.array([x, y, yaw])))
    return out


def localize(data: list[tuple[np.ndarray, np.ndarray]], method: str, voxel: float,
             floor: bool) -> tuple[list[float], list[float]]:
    """ms per scan (deskew + registration) and position error, m."""
    matcher = MapMatcher.from_file(hall_map(), 0.2, method, 1.0, 20)
    ms, err = [], []
    for xyz, (x, y, yaw) in data:
        t0 = time.process_time()
        pts = deskew(xyz[np.einsum("ij,ij->i", xyz[:, :2], xyz[:, :2]) > 1.0], V, W, 10.0)
        if not floor:
            pts = pts[pts[:, 2] > 0.2 - H]
        m = matcher.align(pts, voxel, pose_matrix(x + 0.15, y - 0.13, H, yaw + 0.017))
        ms.append((time.process_time() - t0) * 1e3)
        err.append(float(np.hypot(m.xy_yaw[0] - x, m.xy_yaw[1] - y)))
    return ms, err


def kiss(data: list[tuple[np.ndarray, np.ndarray]]) -> list[float] | None:
    """kiss-icp's odometry step per scan, for comparison (it does not register to a map)."""
    try:
        from kiss_icp.config import KISSConfig  # type: ignore[import-not-found,import-untyped,unused-ignore]
        from kiss_icp.kiss_icp import KissICP  # type: ignore[import-not-found,import-untyped,unused-ignore]
    except ImportError:
        return None
    config = KISSConfig()
    config.data.max_range, config.mapping.voxel_size = 100.0, 1.0  # its defaults for 100 m
    odo = KissICP(config)
    ms = []
    for xyz, _ in data:
        t0 = time.process_time()
        odo.register_frame(xyz[np.isfinite(xyz).all(axis=1)], np.array([]))
        ms.append((time.process_time() - t0) * 1e3)
    return ms[1:]


def detect(data: list[tuple[np.ndarray, np.ndarray]]) -> list[float]:
    """ms per scan: deskew, map frame, ground and map removal, clusters, boxes."""
    mask = MapMask(read_ply(active_project().world_file("winti/hall_map.ply")), 0.12, 2.2)
    ms = []
    for xyz, (x, y, yaw) in data:
        t0 = time.process_time()
        p = deskew(xyz, V, W, 10.0) + np.array([0.0, 0.0, 1.154])
        c, s = math.cos(yaw), math.sin(yaw)
        world = np.column_stack([x + c * p[:, 0] - s * p[:, 1], y + s * p[:, 0] + c * p[:, 1],
                                 0.13 + p[:, 2]])
        clusters(obstacle_points(world, np.array([x, y]), mask, 0.12, 2.2, 0.3, 25.0), 0.5, 3)
        ms.append((time.process_time() - t0) * 1e3)
    return ms


def p95(xs: list[float]) -> float:
    return float(np.percentile(xs, 95))


def report(record: Record, name: str, ms: list[float], note: str = "") -> None:
    record.add(name, "ms", ms, Better.LOWER, note)
    print(f"{name:42s} median {statistics.median(ms):7.2f} ms  p95 {p95(ms):7.2f} ms  {note}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scans", type=int, default=40)
    parser.add_argument("--rtf-s", type=float, default=10.0, help="sim seconds of "
                        "localization_lap for the real-time factor (0: skip)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    record = Record("bench_localization")
    data = scans(args.scans)
    print(f"{len(data)} VLP-16 scans, {statistics.median(len(d[0]) for d in data):.0f} points "
          "each (median)")
    variants: list[tuple[str, str, float, bool]] = [
        ("localization VGICP 0.5 m", "VGICP", 0.5, True),
        ("localization VGICP 0.3 m", "VGICP", 0.3, True),
        ("localization GICP 0.3 m (node default)", "GICP", 0.3, True),
        ("localization GICP 0.5 m", "GICP", 0.5, True),
        ("localization GICP 0.3 m, no floor", "GICP", 0.3, False),
        ("localization ICP 0.3 m", "ICP", 0.3, True),
        ("localization PLANE_ICP 0.3 m", "PLANE_ICP", 0.3, True)]
    for name, method, voxel, floor in variants:
        ms, err = localize(data, method, voxel, floor)
        report(record, name, ms, f"error median {1e3 * statistics.median(err):.1f} mm, "
               f"max {1e3 * max(err):.1f} mm")
    k = kiss(data)
    if k is not None:
        report(record, "kiss-icp odometry step (no map)", k)
    report(record, "detection per scan", detect(data))
    run: Callable[[], None] | None = None
    if args.rtf_s > 0:
        spec = load_scenario("localization_lap", [f"duration_s={args.rtf_s}"],
                             project=active_project())
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            info = simulate(spec, Path(tmp) / "run.mcap")
            rtf = info.sim_time_s / (time.perf_counter() - t0)
        record.add("localization_lap real-time factor", "x", [rtf], Better.HIGHER)
        print(f"localization_lap real-time factor: {rtf:.2f}x ({args.rtf_s:g} s sim)")
    del run
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
