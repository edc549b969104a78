"""The Zenoh bridge: round trip per control tick on loopback (publish the tick's sensors and
/clock to the external program, receive its command for that tick), median and p95, and the
real-time factor of `external_pure_pursuit` (the example stack, a separate process, in
lockstep), beside the in-process driver of the same track (`kart_joy_driver`) for scale.
Prints figures; asserts nothing.

    .venv/bin/python benchmarks/bench_bridge.py [--duration-s 35]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from kartci.sim import Session, simulate
from kartci.spec import load_scenario

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
    spec = load_scenario("external_pure_pursuit", sets)
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
        publish = agent._publish  # serialising and putting the tick's messages, alone

        def timed_publish(t_ns: int) -> None:
            t = time.perf_counter()
            publish(t_ns)
            publish_ms.append((time.perf_counter() - t) * 1e3)

        agent._publish = timed_publish
        while not r.done:
            r = session.step()
        sim_s = session.info().sim_time_s
    return ticks_ms, publish_ms, sim_s / (time.perf_counter() - t0)


def inprocess_rtf(duration_s: float, out: Path) -> float:
    """kart_joy_driver: the same hall, a pure-pursuit driver inside kartci."""
    spec = load_scenario("kart_joy_driver", [f"duration_s={duration_s}"])
    t0 = time.perf_counter()
    info = simulate(spec, out / "joy.mcap")
    return info.sim_time_s / (time.perf_counter() - t0)


def stats(ticks_ms: list[float]) -> str:
    """Median, p95 and max of the ticks."""
    t = sorted(ticks_ms)
    p95 = t[min(len(t) - 1, round(0.95 * len(t)))]
    return (f"{len(t)} ticks (odom + /clock out, AckermannDriveStamped back, loopback): "
            f"median {statistics.median(t):.3f} ms, p95 {p95:.3f} ms, max {t[-1]:.3f} ms")


def main() -> None:
    """Run both and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--duration-s", type=float, default=35.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        echo, pub, _ = external_run(args.duration_s, Path(tmp), echo=True)
        print(f"bridge round trip per control tick, minimal answering stack: {stats(echo)}")
        print(f"  of which serialising and putting the tick's messages: {stats(pub)}")
        ticks, pub, rtf = external_run(args.duration_s, Path(tmp))
        print(f"bridge round trip per control tick, example pure-pursuit stack: {stats(ticks)}")
        print(f"  of which serialising and putting the tick's messages: {stats(pub)}")
        print(f"external_pure_pursuit ({args.duration_s:g} s sim, lockstep): real-time factor "
              f"{rtf:.2f} (includes the stack's start-up)")
        print(f"kart_joy_driver (in-process driver, same hall): real-time factor "
              f"{inprocess_rtf(args.duration_s, Path(tmp)):.2f}")


if __name__ == "__main__":
    main()
