"""Train a kart to drive the hall's track with Stable-Baselines3's PPO through kartci's
Gymnasium env, and print the return of a few greedy episodes before training and after each
round of it, so the return can be seen to rise.

The kart observes its odometry, steering column and place on the track (progress, offset,
heading error, room to each edge, curvature ahead); its reward is its progress along the track
(m); an episode ends on a collision, off the track, in a spin, or after `--duration` s.
Stable-Baselines3 (and PyTorch under it) is not a kartci dependency:

    pip install "kartci[gym]" stable-baselines3
    python examples/gym_sb3_kart.py --rounds 5 --steps 4096
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from gymnasium.wrappers import RescaleAction
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecNormalize

import kartci.gym
from kartci import portable


def normalised(scenario: str, duration_s: float) -> RescaleAction:
    """The kart's env with its action rescaled to [-1, 1] (what PPO's Gaussian policy fits)."""
    env = kartci.gym.make(scenario, duration_s=duration_s)
    one = np.ones(env.action_space.shape, dtype=np.float32)
    return RescaleAction(env, -one, one)


def evaluate(model: PPO, norm: VecNormalize, scenario: str, duration_s: float,
             episodes: int) -> tuple[float, float]:
    """Mean return (m of progress) and mean episode length (s) of greedy episodes."""
    env = normalised(scenario, duration_s)
    returns, lengths = [], []
    for episode in range(episodes):
        obs, info = env.reset(seed=1000 + episode)
        done, ret = False, 0.0
        while not done:
            action, _ = model.predict(norm.normalize_obs(obs), deterministic=True)
            obs, reward, terminated, truncated, info = env.step(action)
            ret += float(reward)
            done = terminated or truncated
        returns.append(ret)
        lengths.append(float(info["t_s"]))
    env.close()
    return float(np.mean(returns)), float(np.mean(lengths))


def main() -> None:
    """Evaluate, then train and evaluate round after round."""
    portable.reexec(sys.argv)  # restart pinned: the same bits as `kartci run` on every CPU
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="kart_manual")
    ap.add_argument("--duration", type=float, default=8.0, help="episode length, s")
    ap.add_argument("--rounds", type=int, default=5, help="training rounds")
    ap.add_argument("--steps", type=int, default=4096, help="env steps per round")
    ap.add_argument("--episodes", type=int, default=3, help="greedy episodes per evaluation")
    args = ap.parse_args()
    venv = VecNormalize(make_vec_env(lambda: normalised(args.scenario, args.duration),
                                     n_envs=1, seed=1), norm_reward=False)
    model = PPO("MlpPolicy", venv, n_steps=1024, batch_size=256, learning_rate=3e-4,
                seed=1, verbose=0)
    ret, length = evaluate(model, venv, args.scenario, args.duration, args.episodes)
    print(f"round 0 (untrained): return {ret:.1f} m, episodes of {length:.2f} s", flush=True)
    for k in range(1, args.rounds + 1):
        model.learn(args.steps, reset_num_timesteps=False)
        venv.training = False
        ret, length = evaluate(model, venv, args.scenario, args.duration, args.episodes)
        venv.training = True
        print(f"round {k} ({k * args.steps} steps): return {ret:.1f} m, episodes of "
              f"{length:.2f} s", flush=True)
    venv.close()


if __name__ == "__main__":
    main()
