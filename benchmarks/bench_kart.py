"""Go-kart speed: real-time factor of kart_manual with and without the VLP-16 at 10 Hz, of
localization_lap (lidar, GICP + EKF node and the MPCC), and the cost of one full VLP-16 /
HDL-32E scan, fast 2.5D model vs PyBullet's batched ray test, measured in one process, medians
of repeats. Each RTF is a whole `simulate()` (build, run, log written) after one warm-up run of
the same scenario, so imports and first-use code generation are not counted. Prints figures;
asserts nothing.

`--parts`: where a kart_manual step (no lidar, 10 s) goes, µs of CPU time per physics step by
part (kartci.sim.parts), and the anchor: f1tenth_gym's one car (single-track model, 1080-beam
lidar, 100 Hz) run alternately with kart_manual in this process, when f110_gym is installed
(skipped with the reason otherwise).

    .venv/bin/python benchmarks/bench_kart.py [--repeats 3] [--parts] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from kartci.bench import Better, Record
from kartci.scenario import load_scenario
from kartci.scenario.models import HallWorld
from kartci.sim import lidar, parts, simulate
from kartci.sim.hall import Hall as World
from kartci.sim.hall import blocks

RUNS: tuple[tuple[str, str, list[str]], ...] = (
    ("kart_manual, no lidar", "kart_manual", []),
    ("kart_manual, VLP-16 10 Hz", "kart_manual", ["agents.kart0.sensors.lidar.enabled=true"]),
    ("localization_lap", "localization_lap", []))


def rtf(name: str, sets: list[str], out: Path) -> float:
    return rtfs(name, sets, out)[0]


def rtfs(name: str, sets: list[str], out: Path) -> tuple[float, float]:
    """Wall-clock and CPU real-time factors of one run (CPU: steadier on a shared machine)."""
    spec = load_scenario(name, sets)
    t0, c0 = time.perf_counter(), time.process_time()
    info = simulate(spec, out / "run.mcap")
    return (info.sim_time_s / (time.perf_counter() - t0),
            info.sim_time_s / (time.process_time() - c0))


def scan_ms(name: str, repeats: int) -> tuple[list[float], list[float], int]:
    spec = load_scenario("kart_replay")
    assert isinstance(spec.world, HallWorld)
    world = World(spec.world, 0.002)
    m = lidar.MODELS[name]
    az = m.azimuths(10.0)
    pos = np.array([8.0, 3.2, 1.281])
    fast, ref = [], []
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            lidar.scan_fast(m, az, pos, 0.3, blocks(spec.world), spec.world.wall_height_m, 100.0)
            fast.append((time.perf_counter() - t0) * 1e3)
            t0 = time.perf_counter()
            lidar.scan_reference(world.client, m, az, pos, 0.3, 100.0)
            ref.append((time.perf_counter() - t0) * 1e3)
    finally:
        world.close()
    return fast, ref, len(az) * len(m.elevations_rad)


def anchor_rtf(steps: int = 2000) -> float | str:
    """Real-time factor of f1tenth_gym's one car (its default map, 100 Hz, driving straight
    at 2 m/s), or why it cannot run here."""
    try:
        from f110_gym.envs.f110_env import F110Env  # optional: the anchor only
    except ImportError as err:
        return (f"f110_gym is not installed ({err.name or err}); it installs from the "
                "f1tenth/f1tenth_gym repository (pip install -e .), not from PyPI")
    env = F110Env(map="vegas", num_agents=1)
    env.reset(np.array([[0.0, 0.0, 0.0]]))
    action = np.array([[0.0, 2.0]])
    t0 = time.perf_counter()
    for _ in range(steps):
        env.step(action)
    return float(steps * env.timestep / (time.perf_counter() - t0))


def step_parts(record: Record, repeats: int, out: Path) -> None:
    """kart_manual (no lidar, 10 s) by part, µs of CPU time per physics step, and the
    f1tenth_gym anchor alternated with it."""
    spec = load_scenario("kart_manual", ["duration_s=10"])
    parts.measure(load_scenario("kart_manual", ["duration_s=0.5"]), out / "warm-up.mcap")
    runs, kart, cpu, anchor = [], [], [], []
    for _ in range(repeats):
        runs.append(parts.measure(spec, out / "parts.mcap"))
        wall, on_cpu = rtfs("kart_manual", ["duration_s=10"], out)
        kart.append(wall)
        cpu.append(on_cpu)
        a = anchor_rtf()
        if isinstance(a, str):
            print(f"f1tenth_gym anchor: skipped: {a}")
        else:
            anchor.append(a)
    print(f"kart_manual, no lidar, 10 s: {runs[0].steps} steps; CPU µs per 2 ms step, "
          f"median of {repeats}")
    for label, us in parts.median_parts(runs).items():
        record.add(f"kart step: {label}", "us", [r.us_per_step[label] for r in runs])
        print(f"  {label:36s} {us:6.1f}")
    record.add("kart_manual 10 s RTF", "x", kart, Better.HIGHER)
    record.add("kart_manual 10 s CPU RTF", "x", cpu, Better.HIGHER)
    print(f"kart_manual, no lidar, 10 s: median RTF {statistics.median(kart):.1f}x, CPU RTF "
          f"{statistics.median(cpu):.1f}x  (" + ", ".join(f"{c:.1f}" for c in cpu) + ")")
    if anchor:
        record.add("f1tenth_gym one car RTF", "x", anchor, Better.HIGHER)
        ratio = [k / a for k, a in zip(kart, anchor, strict=True)]
        record.add("kart_manual RTF / f1tenth_gym RTF", "x", ratio, Better.HIGHER)
        print(f"kart_manual RTF {statistics.median(kart):.1f}x, f1tenth_gym "
              f"{statistics.median(anchor):.1f}x: {statistics.median(ratio):.2f} of it")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--parts", action="store_true",
                        help="only kart_manual's step by part and the f1tenth_gym anchor")
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    args = parser.parse_args()
    record = Record("bench_kart")
    if args.parts:
        with tempfile.TemporaryDirectory() as tmp:
            step_parts(record, args.repeats, Path(tmp))
        if args.json:
            record.save(args.json)
        return
    for name in ("vlp16", "hdl32e"):
        fast, ref, rays = scan_ms(name, max(5, args.repeats))
        f = record.add(f"{name} scan, fast model", "ms", fast)
        r = record.add(f"{name} scan, PyBullet rays", "ms", ref)
        print(f"{name}: {rays} rays per scan; fast model {f.median:.1f} ms, PyBullet rays "
              f"{r.median:.1f} ms (median)")
    with tempfile.TemporaryDirectory() as tmp:
        for label, name, sets in RUNS:
            rtf(name, [*sets, "duration_s=1"], Path(tmp))  # warm-up
            samples = [rtf(name, sets, Path(tmp)) for _ in range(args.repeats)]
            record.add(f"{label} RTF", "x", samples, Better.HIGHER)
            print(f"{label:28s} median RTF {statistics.median(samples):5.1f}x  ("
                  + ", ".join(f"{s:.1f}" for s in samples) + ")")

    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
