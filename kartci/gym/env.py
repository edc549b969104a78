"""`KartciEnv`: one scenario as a Gymnasium environment, stepped one control period at a time
through `kartci.Session`, with the command and observation its robot kind declares
(`RobotKind.control`)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from kartci import core, metrics
from kartci.core import ControlSpace, Metric
from kartci.errors import SpecError, did_you_mean
from kartci.scenario import Scenario
from kartci.scenario.load import load_scenario
from kartci.sim.session import Session, StepResult

Observation = np.ndarray[Any, Any]  # float32, one value per channel
# (previous observation, observation) -> the step's reward
Reward = Callable[[Observation, Observation], float]
SEED_RANGE = 2**31  # episode seeds drawn from the env's generator: 0 .. 2**31 - 1


def override_strings(overrides: Mapping[str, object]) -> list[str]:
    """`key=value` assignments as `--set` takes them (values as YAML: JSON for non-strings)."""
    return [f"{k}={v if isinstance(v, str) else json.dumps(v)}" for k, v in overrides.items()]


def driven_m(names: Sequence[str]) -> Reward:
    """The default reward: metres driven in the step (odometry x, y), a placeholder for a
    task's own; 0 for a robot whose observation has no `x_m`, `y_m`."""
    if "x_m" not in names or "y_m" not in names:
        return lambda prev, obs: 0.0
    ix, iy = names.index("x_m"), names.index("y_m")
    return lambda prev, obs: math.hypot(float(obs[ix] - prev[ix]), float(obs[iy] - prev[iy]))


class _Listener:
    """Stands in for the controlled agent's controller: keeps the latest message of each input
    and commands nothing itself (the env publishes the action through `Session.command`)."""

    def __init__(self, period_s: float, inputs: tuple[str, ...]) -> None:
        self.period_s, self.inputs = period_s, inputs
        self.latest: dict[str, Any] = {}

    def on_message(self, topic: str, message: Any) -> None:
        """Keep it as the topic's latest."""
        self.latest[topic] = message

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        """Nothing: the env's action is the command."""
        return []


class KartciEnv(gym.Env[Observation, Observation]):
    """A scenario as a Gymnasium environment: one `step` is one control period of the
    controlled agent (its scenario controller's `period_s`), the action its robot kind's command,
    the observation its kind's numbers at the control tick (clipped to the space).

    The other agents keep their scenario controllers. The last step of an episode is shorter
    when `duration_s` is not a whole number of periods. An episode ends as the scenario's run
    does: `terminated` when every robot finished its course, `truncated` when `duration_s` ran
    out. `reset(seed=s)` runs the scenario with `seed: s` (its noise); `reset()` runs the
    scenario's own seed first, then seeds drawn from the env's generator. Each episode is a new
    `Session` (a new PyBullet client, the last one closed first).

    Args:
        scenario: A scenario name or YAML path, or a loaded `Scenario`.
        agent: The agent the env drives (default: the scenario's first).
        log_dir: Where each episode's MCAP log goes (`episode-000001.mcap`, ...); at the end of
            an episode `info["log"]` names it and `info["metrics"]` holds its metrics, computed
            from the log by the same code as `kartci run`. None: no log.
        reward: `(previous observation, observation) -> float`; default `driven_m`.
        overrides: `dotted.key=value` assignments, as `kartci.run` and `--set` take them.
        **values: Top-level scenario values as keywords (`duration_s=5`), applied after
            `overrides`.
    """

    metadata = {"render_modes": []}  # noqa: RUF012  (Env declares it an instance attribute)

    def __init__(self, scenario: str | Path | Scenario, *, agent: str | None = None,
                 log_dir: str | Path | None = None, reward: Reward | None = None,
                 render_mode: str | None = None, overrides: Sequence[str] = (),
                 **values: object) -> None:
        if render_mode is not None:
            raise SpecError(f"kartci.gym: render_mode {render_mode!r}: kartci renders nothing "
                            "live; open the episode's log (log_dir) in Foxglove")
        sets = [*overrides, *override_strings(values)]
        if not isinstance(scenario, Scenario):
            scenario = load_scenario(scenario, sets)
        elif sets:
            scenario = load_scenario(scenario.name, sets)
        self.scenario = scenario
        self.agent = agent or next(iter(scenario.agents))
        if self.agent not in scenario.agents:
            raise SpecError(f"kartci.gym: scenario {scenario.name} has no agent "
                            f"'{self.agent}'{did_you_mean(self.agent, scenario.agents)}")
        spec = scenario.agents[self.agent]
        kind = core.ROBOTS.get(spec.model.kind)
        if kind.control is None:
            raise SpecError(f"kartci.gym: robot kind {kind.name} declares no command and "
                            "observation vectors (RobotKind.control)")
        self.space: ControlSpace = kind.control(spec.model)
        self.period_s = spec.controller.period_s
        self.every = max(1, round(self.period_s / scenario.physics.dt_s))
        self.action_names = tuple(c.name for c in self.space.command)
        self.observation_names = tuple(c.name for c in self.space.observation)
        self.action_box, self.observation_box = (_box(self.space.command),
                                                 _box(self.space.observation))
        self.action_space, self.observation_space = self.action_box, self.observation_box
        self.log_dir = None if log_dir is None else Path(log_dir)
        self.reward_fn = reward or driven_m(self.observation_names)
        self.episodes = 0
        self._session: Session | None = None
        self._listener: _Listener | None = None
        self._obs: Observation | None = None
        self._seeded = False

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Observation, dict[str, Any]]:
        """Start an episode: a new run of the scenario, at t = 0 (see the class for seeds)."""
        if seed is None and not self._seeded:
            seed = self.scenario.seed
        super().reset(seed=seed)
        self._seeded = True
        if seed is None:
            seed = int(self.np_random.integers(SEED_RANGE))
        self.close()
        self.episodes += 1
        log = None
        if self.log_dir is not None:
            self.log_dir.mkdir(parents=True, exist_ok=True)
            log = self.log_dir / f"episode-{self.episodes:06d}.mcap"
        self._listener = _Listener(self.period_s, self.space.inputs)
        scenario = self.scenario.model_copy(update={"seed": seed})
        self._session = Session(scenario, log, {self.agent: self._listener})
        r = self._session.reset()
        self._obs = self._observe()
        return self._obs.copy(), self._info(r, seed)

    def step(self, action: Observation) -> tuple[Observation, SupportsFloat, bool, bool,
                                                 dict[str, Any]]:
        """Command `action` (clipped to the space) now, then run one control period."""
        s = self._session
        if s is None or self._obs is None or s.done:
            raise SpecError("kartci.gym: step() before reset() or after the episode ended")
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != self.action_box.shape:
            raise SpecError(f"kartci.gym: an action is {self.action_box.shape[0]} numbers "
                            f"({', '.join(self.action_names)}), not {a.size}")
        a = np.clip(a, self.action_box.low, self.action_box.high)
        s.command(self.agent, self.space.topic,
                  self.space.build(tuple(float(v) for v in a), s.t_ns, self.agent))
        r = s.step()
        while not r.done and r.step % self.every:
            r = s.step()
        prev, self._obs = self._obs, self._observe()
        reward = float(self.reward_fn(prev, self._obs))
        info = self._info(r, s.scenario.seed)
        if r.done:
            self._end(info)
        return (self._obs.copy(), reward, r.done and r.finished_course,
                r.done and not r.finished_course, info)

    def _observe(self) -> Observation:
        assert self._listener is not None
        values = np.asarray(self.space.read(self._listener.latest), dtype=np.float32)
        return np.clip(values, self.observation_box.low, self.observation_box.high)

    def _info(self, r: StepResult, seed: int) -> dict[str, Any]:
        return {"t_s": r.t_s, "step": r.step, "seed": seed}

    def _end(self, info: dict[str, Any]) -> None:
        """Close the episode's run (writing its log) and score the log."""
        s = self._session
        assert s is not None
        s.close()
        if s.log_path is not None:
            info["log"] = s.log_path
            info["metrics"] = score(s.log_path)

    def close(self) -> None:
        """Release the episode's simulator (its log is written as a shorter run's)."""
        if self._session is not None:
            self._session.close()
            self._session = None


def _box(channels: Sequence[core.Channel]) -> spaces.Box:
    return spaces.Box(np.array([c.low for c in channels], dtype=np.float32),
                      np.array([c.high for c in channels], dtype=np.float32), dtype=np.float32)


def score(log: Path) -> dict[str, Metric]:
    """A log's metrics, by the same code as `kartci run` (`kartci.metrics.compute`)."""
    return metrics.compute(log)[1]
