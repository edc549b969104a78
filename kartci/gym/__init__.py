"""Gymnasium environments for any scenario (`pip install 'kartci[gym]'`).

```python
import gymnasium
import kartci.gym

env = kartci.gym.make("line_straight", duration_s=5)   # or:
env = gymnasium.make("kartci/line_straight-v0", duration_s=5)
obs, info = env.reset(seed=1)
obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
```

Importing `kartci.gym` registers `kartci/<scenario>-v0` for every scenario reachable by name
(the project's, then the built-in ones); `gymnasium.make("kartci.gym:kartci/<scenario>-v0")`
imports it on the way. (Gymnasium 1.0 dropped loading environments from entry points, so the
import is what registers them.) The action and observation are the controlled robot kind's
(`RobotKind.control`: a kart's steering, acceleration and brake; a line tracker's wheel speeds),
one `step` is one control period, and each episode may be logged and scored (`log_dir`). Where
the world has a course the robot also observes its place on it, is rewarded for progress along
it, and an episode ends on a collision, off the course or on loss of control. See `KartciEnv`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

try:
    import gymnasium
except ImportError as err:  # the optional extra is not installed
    raise ImportError("kartci.gym needs Gymnasium: pip install 'kartci[gym]'") from err

from kartci import project
from kartci.gym.env import (
    TERMINAL,
    Ending,
    KartciEnv,
    Reward,
    course_channels,
    driven_m,
    progress_m,
    score,
)
from kartci.scenario import Scenario
from kartci.scenario.load import scenario_names

NAMESPACE = "kartci"
VERSION = 0  # of every kartci env id: kartci/<scenario>-v0


def env_id(scenario: str) -> str:
    """The Gymnasium id of a scenario's env."""
    return f"{NAMESPACE}/{scenario}-v{VERSION}"


def register_scenarios() -> list[str]:
    """Register an env id for every scenario reachable by name (again after new files appear);
    returns the ids."""
    ids = []
    for name in scenario_names(project.current()):  # an entry point, as kartci.api
        ids.append(env_id(name))
        if ids[-1] not in gymnasium.registry:
            gymnasium.register(ids[-1], entry_point="kartci.gym.env:KartciEnv",
                               kwargs={"scenario": name})
    return ids


def make(scenario: str | Path | Scenario, overrides: Sequence[str] = (), *,
         agent: str | None = None, log_dir: str | Path | None = None,
         reward: Reward | None = None, end_on: Iterable[Ending | str] = TERMINAL,
         **values: Any) -> KartciEnv:
    """The env of a scenario name, YAML path or `Scenario`, with `--set`-style overrides
    (`["agents.lt0.controller.period_s=0.02"]`) and top-level values as keywords
    (`duration_s=5`); see `KartciEnv`."""
    return KartciEnv(scenario, agent=agent, log_dir=log_dir, reward=reward,
                     overrides=overrides, end_on=end_on, **values)


register_scenarios()

__all__ = ["Ending", "KartciEnv", "Reward", "course_channels", "driven_m", "env_id", "make",
           "progress_m", "register_scenarios", "score"]
