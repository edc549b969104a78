"""Real-time factor (sim seconds per wall second) of the line scenarios, geometric vs rendered
line sensor, measured in one process, median of repeats; with the same factor over the process's
CPU time (steadier on a shared machine) and the physics alone (PyBullet's step for as many steps:
the ceiling for the whole loop). Prints figures; asserts nothing.

`--parts`: where a step of each line scenario (geometric sensor) goes, µs of CPU time per
physics step by part (kartci.sim.parts), medians of repeats.

    .venv/bin/python benchmarks/bench_line.py [--repeats 3] [--parts] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from kartci._bullet import pb
from kartci.bench import Better, Record
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import parts, simulate
from kartci.sim.session import Session

SCENARIOS = ("line_straight", "line_circle")
MODES = ("geometric", "rendered")


def rtf(name: str, mode: str, out: Path) -> tuple[float, float]:
    """Wall-clock and CPU real-time factors of one run."""
    spec = load_scenario(name, [f"agents.lt0.sensors.line_sensor.mode={mode}"],
                         project=active_project())
    t0, c0 = time.perf_counter(), time.process_time()
    info = simulate(spec, out / f"{name}-{mode}.mcap")
    return (info.sim_time_s / (time.perf_counter() - t0),
            info.sim_time_s / (time.process_time() - c0))


def physics_rtf(name: str, steps: int = 5000) -> float:
    """Real-time factor of PyBullet's step alone (wheel motor commands included) in the
    scenario's world, after 100 steps of the scenario's own loop."""
    spec = load_scenario(name, project=active_project())
    with Session(spec, None) as s:
        s.reset()
        for _ in range(100):
            s.step()
        robot = s.world.robots[0]
        c = s.world.client
        t0 = time.perf_counter()
        for k in range(steps):
            robot.pre_step(k)
            pb.stepSimulation(physicsClientId=c)
        return steps * spec.physics.dt_s / (time.perf_counter() - t0)


def step_parts(record: Record, repeats: int, out: Path) -> None:
    """Each line scenario's step by part, CPU µs per physics step, median of repeats."""
    parts.measure(load_scenario("line_circle", ["duration_s=0.5"],
                                project=active_project()), out / "warm-up.mcap")
    for name in SCENARIOS:
        runs = [parts.measure(load_scenario(name, project=active_project()), out / f"{name}.mcap")
                for _ in range(repeats)]
        print(f"{name}, geometric sensor: {runs[0].steps} steps; CPU µs per 2 ms step, median "
              f"of {repeats}")
        for label, us in parts.median_parts(runs).items():
            record.add(f"{name} step: {label}", "us", [r.us_per_step[label] for r in runs])
            print(f"  {label:36s} {us:6.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    parser.add_argument("--parts", action="store_true",
                        help="only each line scenario's step by part")
    args = parser.parse_args()
    record = Record("bench_line")
    if args.parts:
        with tempfile.TemporaryDirectory() as tmp:
            step_parts(record, args.repeats, Path(tmp))
        if args.json:
            record.save(args.json)
        return
    print(f"{'scenario':15s} {'sensor':10s} {'median RTF':>10s} {'CPU RTF':>8s}  wall samples")
    with tempfile.TemporaryDirectory() as tmp:
        # warm-up, not timed: imports and message-type registration happen on the first run
        simulate(load_scenario("line_circle", ["duration_s=0.5",
                                               "agents.lt0.sensors.line_sensor.mode=rendered"],
                                               project=active_project()),
                 Path(tmp) / "warm-up.mcap")
        for name in SCENARIOS:
            for mode in MODES:
                wall, cpu = zip(*(rtf(name, mode, Path(tmp)) for _ in range(args.repeats)),
                                strict=True)
                record.add(f"{name} {mode} RTF", "x", wall, Better.HIGHER)
                record.add(f"{name} {mode} CPU RTF", "x", cpu, Better.HIGHER)
                print(f"{name:15s} {mode:10s} {statistics.median(wall):9.1f}x "
                      f"{statistics.median(cpu):7.1f}x  " + ", ".join(f"{s:.1f}" for s in wall))
        for name in SCENARIOS:
            phys = [physics_rtf(name) for _ in range(args.repeats)]
            record.add(f"{name} physics-only RTF", "x", phys, Better.HIGHER)
            print(f"{name:15s} {'physics':10s} {statistics.median(phys):9.1f}x "
                  f"{'':7s}   " + ", ".join(f"{s:.1f}" for s in phys))

    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
