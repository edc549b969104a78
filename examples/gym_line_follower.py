"""A scripted policy through kartci's Gymnasium env: a line tracker steers towards the darker
of its two line-sensor readings. It trains nothing; it shows the loop a learning agent runs,
one episode's log and the metrics `kartci run` would compute from it.

    pip install 'kartci[gym]'
    python examples/gym_line_follower.py --episodes 2 --duration 3 --log-dir reports/gym
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import kartci.gym
from kartci import portable

BASE_RADPS = 6.0  # wheel speed on a straight line, rad/s
TURN_RADPS_PER_LUMINANCE = 30.0  # steering gain: wheel-speed difference per luminance difference


def policy(obs: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Wheel speeds that turn towards the darker sensor (the line is dark, the floor light)."""
    left, right = obs[names.index("line_left")], obs[names.index("line_right")]
    turn = TURN_RADPS_PER_LUMINANCE * float(left - right)  # left brighter: turn right
    return np.array([BASE_RADPS + turn, BASE_RADPS - turn], dtype=np.float32)


def main() -> None:
    """Run the episodes and print each one's return and a few of its metrics."""
    portable.reexec(sys.argv)  # restart pinned: the same bits as `kartci run` on every CPU
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="line_straight")
    ap.add_argument("--episodes", type=int, default=2)
    ap.add_argument("--duration", type=float, default=3.0, help="episode length, s")
    ap.add_argument("--log-dir", type=Path, default=None, help="keep and score each episode")
    args = ap.parse_args()
    env = kartci.gym.make(args.scenario, ["metrics.line_tracking.transient_s=1"],
                          log_dir=args.log_dir, duration_s=args.duration)
    for episode in range(args.episodes):
        obs, info = env.reset(seed=episode)
        ret, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(
                policy(obs, env.observation_names))
            ret += float(reward)
            done = terminated or truncated
        line = f"episode {episode} seed {info['seed']}: {info['t_s']:.2f} s, return {ret:.3f} m"
        if "metrics" in info:
            m = info["metrics"]["cross_track_max_m"]
            line += f", cross_track_max_m {m.value:.4f} {m.unit}, log {info['log']}"
        print(line)
    env.close()


if __name__ == "__main__":
    main()
