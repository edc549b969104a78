"""Steps per second of kartci's Gymnasium envs: one env, and two in a Gymnasium
`AsyncVectorEnv` (a worker process each), on a kart (`kart_manual`, one step = one 20 ms
control period = 10 physics steps) and a line tracker (`line_straight`, 60 ms = 30 physics
steps), random actions, episodes reset as they end; median of repeats, in one process. Prints
figures; asserts nothing.

    .venv/bin/python benchmarks/bench_gym.py [--steps 500] [--repeats 3] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import gymnasium

import kartci.gym
from kartci.bench import Better, Record

SCENARIOS = ("kart_manual", "line_straight")


def single(name: str, steps: int) -> float:
    """Env steps per second of one env (resets included)."""
    env = kartci.gym.make(name)
    env.action_space.seed(1)
    env.reset(seed=1)
    t0 = time.perf_counter()
    for _ in range(steps):
        *_, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    rate = steps / (time.perf_counter() - t0)
    env.close()
    return rate


def vectorised(name: str, steps: int, workers: int = 2) -> float:
    """Env steps per second (all workers' steps) of `workers` envs in an AsyncVectorEnv
    (autoreset: an ended episode resets on the next step)."""
    envs = gymnasium.vector.AsyncVectorEnv(
        [lambda: kartci.gym.make(name) for _ in range(workers)])
    envs.action_space.seed(1)
    envs.reset(seed=1)
    t0 = time.perf_counter()
    for _ in range(steps // workers):
        envs.step(envs.action_space.sample())
    rate = (steps // workers) * workers / (time.perf_counter() - t0)
    envs.close()
    return rate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    args = parser.parse_args()
    record = Record("bench_gym")
    single(SCENARIOS[0], 20)  # warm-up: imports and the first world
    print(f"{'scenario':15s} {'env':22s} {'median steps/s':>14s}  samples")
    for name in SCENARIOS:
        for label, fn in (("one env", single), ("AsyncVectorEnv, 2", vectorised)):
            rates = [fn(name, args.steps) for _ in range(args.repeats)]
            record.add(f"{name} {label} steps/s", "1/s", rates, Better.HIGHER)
            print(f"{name:15s} {label:22s} {statistics.median(rates):14.0f}  "
                  + ", ".join(f"{r:.0f}" for r in rates))
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
