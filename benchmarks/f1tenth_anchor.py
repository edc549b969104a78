"""The f1tenth_gym anchor of bench_kart.py: its one car stepped in its own interpreter (the side
venv that benchmarks/make_f1tenth_env.sh builds; f110_gym's gym / numba stack never enters
kartci's), printing one JSON line: the real-time factors of the stepping loop alone, wall and
CPU (the import, numba's cache load, the map's set-up and a warm-up are not timed).

The car is f1tenth_gym's default: single-track model, RK4, `env.timestep` 0.01 s (100 Hz), its
1080-beam lidar (4.7 rad) ray-marched on every step, on its default map (vegas, shipped in the
repository). It drives straight at 2 m/s from a pose on a straight of the map; from the origin
(heading 0) it would hit the wall after 5.8 m. Exit 1 if it collides, so a stalled car is never
timed.

    KARTCI_F1TENTH_PYTHON benchmarks/f1tenth_anchor.py [--steps 2000]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from importlib.metadata import version

import numpy as np
from f110_gym.envs.f110_env import F110Env

# x m, y m, yaw rad: the 2000 steps go 39.6 m straight on, the lidar's nearest return >= 1.9 m
START = np.array([[5.0, -1.8, -0.49]])
ACTION = np.array([[0.0, 2.0]])  # steering rad, speed m/s
WARM_UP_STEPS = 100


def drive(env: F110Env, steps: int) -> int:
    """Step on from where the car is; the number of steps that ended in a collision."""
    hits = 0
    for _ in range(steps):
        obs = env.step(ACTION)[0]
        hits += int(obs["collisions"][0])
    return hits


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=2000, help="timed steps (0.01 s each)")
    steps = parser.parse_args().steps
    env = F110Env(num_agents=1)  # no `map`: the default, vegas
    env.reset(START)
    drive(env, WARM_UP_STEPS)
    env.reset(START)
    t0, c0 = time.perf_counter(), time.process_time()
    hits = drive(env, steps)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if hits:
        sys.exit(f"f1tenth_gym's car collided in {hits} of {steps} steps: not timed")
    print(json.dumps({
        "rtf": steps * env.timestep / wall, "cpu_rtf": steps * env.timestep / cpu,
        "steps": steps, "timestep_s": env.timestep, "beams": env.sim.agents[0].num_beams,
        "versions": {p: version(p) for p in ("f110_gym", "gym", "numpy", "numba")}}))


if __name__ == "__main__":
    main()
