"""Where a run's step time goes: each part of the loop (physics, actuators, sensors and
messages, controller, log) timed on its own, exclusive of the parts it calls. For the
benchmarks (`benchmarks/bench_kart.py --parts`, `bench_line.py --parts`); not used by a run.

The clock is the thread's CPU time: on a shared machine, wall time counts the other
processes' turns too. Reading it costs about a microsecond a call, so the timers' own cost is
measured and reported as a part of its own.
"""

from __future__ import annotations

import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kartci.scenario import Scenario
from kartci.sim.session import Session

CLOCK = time.thread_time_ns


class _Clock:
    """Exclusive time per label of the methods wrapped with `wrap`, ns."""

    def __init__(self) -> None:
        self.spent: dict[str, int] = defaultdict(int)
        self.calls: dict[str, int] = defaultdict(int)
        self._inner: list[int] = []  # time of the wrapped calls inside each open call, ns

    def wrap(self, obj: object, attr: str, label: str) -> None:
        """Time `obj.attr(...)` under `label` from now on (an instance attribute)."""
        f: Callable[..., Any] = getattr(obj, attr)
        spent, calls, inner = self.spent, self.calls, self._inner

        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = CLOCK()
            inner.append(0)
            try:
                return f(*args, **kwargs)
            finally:
                dt = CLOCK() - t0
                spent[label] += dt - inner.pop()
                calls[label] += 1
                if inner:
                    inner[-1] += dt

        setattr(obj, attr, timed)


@dataclass(frozen=True)
class Parts:
    """One run's step time by part: µs per physics step and calls per step."""

    steps: int
    us_per_step: dict[str, float]
    calls_per_step: dict[str, float]


def _overhead_ns() -> float:
    """What one wrapped call costs the clock beyond the call itself, ns."""
    clock = _Clock()

    class Nothing:
        def f(self) -> None:
            """Does nothing."""

    n = Nothing()
    clock.wrap(n, "f", "f")
    t0 = CLOCK()
    for _ in range(20_000):
        n.f()
    return (CLOCK() - t0 - clock.spent["f"]) / 20_000


def measure(scenario: Scenario, log_path: Path) -> Parts:
    """Run `scenario` to its end (logged to `log_path`) with every part timed."""
    clock = _Clock()
    with Session(scenario, log_path) as s:
        s.reset()
        clock.wrap(s.world, "step", "physics (stepSimulation)")
        for robot in s.world.robots:
            clock.wrap(robot, "pre_step", "actuators (tyre forces, motors)")
            clock.wrap(robot, "post_step", "contacts")
            clock.wrap(robot, "sense", "sensors and their messages")
            clock.wrap(robot.agent, "step", "controller")
            clock.wrap(robot.agent, "on_message", "controller inputs")
        log = s._log  # the run's writer: its serialisation and its MCAP records
        if log is not None:
            clock.wrap(log, "write", "log: CDR serialisation")
            for obj, attr in ((log, "_flush"), (log._writer, "add_message")):
                if hasattr(obj, attr):  # records in batches, or (writers before) one at a time
                    clock.wrap(obj, attr, "log: MCAP records")
        t0 = CLOCK()
        s.run_to_end(None)  # as simulate() steps
        total = CLOCK() - t0
        steps = s.k
    timers = _overhead_ns() * sum(clock.calls.values())
    us = {label: ns / steps / 1e3 for label, ns in clock.spent.items()}
    us["timers (measurement)"] = timers / steps / 1e3
    us["loop, message bus"] = (total - sum(clock.spent.values()) - timers) / steps / 1e3
    us["total"] = total / steps / 1e3
    return Parts(steps, us, {k: v / steps for k, v in clock.calls.items()})


def median_parts(runs: list[Parts]) -> dict[str, float]:
    """Each part's median over runs, µs per step."""
    return {k: statistics.median(r.us_per_step[k] for r in runs) for k in runs[0].us_per_step}
