"""The lockstep's cost per control tick with external stacks, one and two processes, over Zenoh
and Fast DDS: the wall time of each tick's bridge step (publish the tick's messages, wait for the
stack, take its answers), median and p99, the first tick (start-up) not counted. Wraps only
`agent.step`, so the same script measures an older kartci too (run it with that checkout first on
PYTHONPATH); the stacks' programs are always this checkout's examples. Prints figures; asserts
nothing.

    .venv/bin/python benchmarks/bench_lockstep.py [--duration-s 10] [--only zenoh-two] [--json F]
    PYTHONPATH=../old .venv/bin/python benchmarks/bench_lockstep.py ...   # the same, before
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from kartci.bench import Figure, Record
from kartci.errors import KartciError
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import Session

ROOT = Path(__file__).resolve().parents[1]
ZENOH = ROOT / "examples" / "zenoh_stack"
ROS2 = ROOT / "examples" / "ros2_stack"
TWO_ZENOH = (f'["sh", "-c", "{{python}} {ZENOH}/odom_relay.py & exec {{python}} '
             f'{ZENOH}/kart_driver.py --odom-topic odom_relay"]')
TWO_DDS = ('["sh", "-c", "{ros_python} odom_relay_node.py --ros-args -r __ns:=/{namespace} '
           '-p use_sim_time:=true -p qos:=sensor_data & exec {ros_python} pure_pursuit_node.py '
           '--ros-args -r __ns:=/{namespace} -p use_sim_time:=true -r track:=/kartci/track '
           '-r odom:=odom_relay -p qos:=sensor_data"]')
CASES = {  # name: (project folder, scenario, overrides)
    "zenoh-one": (ROOT, "external_pure_pursuit",
                  [f'agents.kart0.controller.command=["{{python}}", "{ZENOH}/kart_driver.py"]']),
    "zenoh-two": (ROOT, "external_pure_pursuit", [f"agents.kart0.controller.command={TWO_ZENOH}"]),
    "dds-one": (ROS2, "dds_pure_pursuit", []),
    "dds-two": (ROS2, "dds_pure_pursuit", [f"agents.kart0.controller.command={TWO_DDS}"]),
    "dds-two-reliable": (ROS2, "dds_pure_pursuit", [
        f"agents.kart0.controller.command={TWO_DDS.replace('sensor_data', 'default')}"]),
}


def ticks_ms(case: str, duration_s: float, out: Path) -> list[float]:
    """Each control tick's bridge step (ms), the first one (start-up) left out."""
    folder, name, sets = CASES[case]
    here = Path.cwd()
    os.chdir(folder)
    try:
        spec = load_scenario(name, [f"duration_s={duration_s}", *sets], project=active_project())
        found: list[float] = []
        with Session(spec, out / f"{case}.mcap") as session:
            r = session.reset()
            agent: Any = session.world.robots[0].agent
            step = agent.step

            def timed(t_ns: int) -> Any:
                t = time.perf_counter()
                got = step(t_ns)
                found.append((time.perf_counter() - t) * 1e3)
                return got

            agent.step = timed
            while not r.done:
                r = session.step()
    finally:
        os.chdir(here)
    return found[1:]


def main() -> None:
    """Run each case; print the figures (and write JSON)."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--duration-s", type=float, default=10.0)
    parser.add_argument("--only", choices=sorted(CASES), action="append")
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    args = parser.parse_args()
    record = Record("bench_lockstep")
    with tempfile.TemporaryDirectory() as tmp:
        for case in args.only or sorted(CASES):
            try:
                samples = ticks_ms(case, args.duration_s, Path(tmp))
            except KartciError as err:  # an older kartci may not run a case at all
                print(f"{case}: failed: {err}", flush=True)
                continue
            fig: Figure = record.add(f"bridge step per tick, {case}", "ms", samples)
            p99 = sorted(fig.samples)[min(len(fig.samples) - 1, int(0.99 * len(fig.samples)))]
            print(f"{case}: {len(fig.samples)} ticks, median {fig.median:.3f} ms, "
                  f"p99 {p99:.3f} ms, max {max(fig.samples):.3f} ms", flush=True)
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
