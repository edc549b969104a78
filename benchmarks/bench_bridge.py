"""The Zenoh bridge: round trip per control tick on loopback (publish the tick's sensors and
/clock to the external program, receive its command for that tick), median and p95, and the
real-time factor of `external_pure_pursuit` (the example stack, a separate process, in
lockstep), beside the in-process driver of the same track (`kart_joy_driver`) for scale.
Prints figures; asserts nothing.

    .venv/bin/python benchmarks/bench_bridge.py [--duration-s 35] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

from kartci.bench import Better, Figure, Record
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import Session, simulate

ECHO = Path(__file__).resolve().parents[1] / "tests" / "bridge" / "zenoh_listener.py"


def external_run(duration_s: float, out: Path,
                 echo: bool = False) -> tuple[list[float], list[float], float]:
    """Every control tick's bridge step (ms) and the run's real-time factor; `echo`: the
    stack is the tests' minimal zenoh-only answerer (replies inside its network callback)
    instead of the example driver."""
    sets = [f"duration_s={duration_s}"]
    if echo:
        sets.append(f'agents.kart0.controller.command=["{{python}}", "{ECHO}", '
                    f'"{out / "echo.json"}", "kart0"]')
    spec = load_scenario("external_pure_pursuit", sets, project=active_project())
    ticks_ms: list[float] = []
    publish_ms: list[float] = []
    t0 = time.perf_counter()
    with Session(spec, out / "run.mcap") as session:
        r = session.reset()  # the first tick includes the stack's start-up: not counted
        agent: Any = session.world.robots[0].agent
        step = agent.step

        def timed(t_ns: int) -> Any:
            t = time.perf_counter()
            got = step(t_ns)
            ticks_ms.append((time.perf_counter() - t) * 1e3)
            return got

        agent.step = timed
        def timing(publish: Any) -> Any:  # serialising and putting, alone
            def timed_publish(t_ns: int) -> None:
                t = time.perf_counter()
                publish(t_ns)
                publish_ms.append((time.perf_counter() - t) * 1e3)
            return timed_publish

        agent._publish_sensors = timing(agent._publish_sensors)
        agent._publish_clock = timing(agent._publish_clock)
        while not r.done:
            r = session.step()
        sim_s = session.info().sim_time_s
    return ticks_ms, publish_ms, sim_s / (time.perf_counter() - t0)


def inprocess_rtf(duration_s: float, out: Path) -> float:
    """kart_joy_driver: the same hall, a pure-pursuit driver inside kartci."""
    spec = load_scenario("kart_joy_driver", [f"duration_s={duration_s}"], project=active_project())
    t0 = time.perf_counter()
    info = simulate(spec, out / "joy.mcap")
    return info.sim_time_s / (time.perf_counter() - t0)


def stats(fig: Figure) -> str:
    """Count, median, p95 and max of a figure's ticks."""
    return (f"{len(fig.samples)} ticks: median {fig.median:.3f} ms, p95 {fig.p95:.3f} ms, "
            f"max {max(fig.samples):.3f} ms")


def main() -> None:
    """Run both stacks and the in-process reference; print the figures (and write JSON)."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--duration-s", type=float, default=35.0)
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    args = parser.parse_args()
    record = Record("bench_bridge")
    what = "odom + /clock out, AckermannDriveStamped back, loopback"
    with tempfile.TemporaryDirectory() as tmp:
        for label, echo in (("minimal answering stack", True), ("example pure-pursuit stack",
                                                                False)):
            ticks, pub, rtf = external_run(args.duration_s, Path(tmp), echo=echo)
            t = record.add(f"round trip per tick, {label}", "ms", ticks, note=what)
            p = record.add(f"serialise and put per publication, {label}", "ms", pub)
            print(f"bridge round trip per control tick ({what}), {label}: {stats(t)}")
            print(f"  of which serialising and putting one publication (the sensors, or "
                  f"/clock): {stats(p)}")
        record.add("external_pure_pursuit RTF", "x", [rtf], Better.HIGHER,
                   note="lockstep, includes the stack's start-up")
        print(f"external_pure_pursuit ({args.duration_s:g} s sim, lockstep): real-time factor "
              f"{rtf:.2f} (includes the stack's start-up)")
        ref = inprocess_rtf(args.duration_s, Path(tmp))
        record.add("kart_joy_driver RTF", "x", [ref], Better.HIGHER,
                   note="in-process driver, same hall")
        print(f"kart_joy_driver (in-process driver, same hall): real-time factor {ref:.2f}")
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
