"""`KartciEnv`: one scenario as a Gymnasium environment, stepped one control period at a time
through `kartci.Session`, with the command and observation its robot kind declares
(`RobotKind.control`)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from enum import Enum
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from kartci import core, metrics, project
from kartci._bullet import pb
from kartci.core import ControlSpace, Metric
from kartci.core.course import Course
from kartci.errors import SpecError, did_you_mean
from kartci.scenario import Scenario
from kartci.scenario.load import in_project, load_scenario
from kartci.sim.session import Session, StepResult

Observation = np.ndarray[Any, Any]  # float32, one value per channel
# (previous observation, observation) -> the step's reward
Reward = Callable[[Observation, Observation], float]
SEED_RANGE = 2**31  # episode seeds drawn from the env's generator: 0 .. 2**31 - 1


def override_strings(overrides: Mapping[str, object]) -> list[str]:
    """`key=value` assignments as `--set` takes them (values as YAML: JSON for non-strings)."""
    return [f"{k}={v if isinstance(v, str) else json.dumps(v)}" for k, v in overrides.items()]


COURSE_BOUND = 1e5  # bound of the course channels (m, 1/m): any course here fits


class Ending(Enum):
    """Why an episode ended (`info["ending"]` on its last step)."""

    FINISHED = "finished"  # every robot finished its course (terminated)
    COLLISION = "collision"  # the robot touched something but the floor (terminated)
    OFF_COURSE = "off_course"  # beyond the course's room, a track's edge (terminated)
    LOST_CONTROL = "lost_control"  # its kind says so: a spin, a line lost (terminated)
    TIME = "time"  # duration_s ran out (truncated)


TERMINAL = (Ending.COLLISION, Ending.OFF_COURSE, Ending.LOST_CONTROL)  # end_on's default


def driven_m(names: Sequence[str]) -> Reward:
    """Metres driven in the step (odometry x, y), for a world without a course; 0 for a
    robot whose observation has no `x_m`, `y_m`."""
    if "x_m" not in names or "y_m" not in names:
        return lambda prev, obs: 0.0
    ix, iy = names.index("x_m"), names.index("y_m")
    return lambda prev, obs: math.hypot(float(obs[ix] - prev[ix]), float(obs[iy] - prev[iy]))


def progress_m(names: Sequence[str]) -> Reward:
    """The default reward where the world has a course: metres of progress along it in the
    step (backwards negative), so a lap's return is its length whatever the line taken."""
    if "progress_m" not in names:
        return driven_m(names)
    i = names.index("progress_m")
    return lambda prev, obs: float(obs[i] - prev[i])


def course_channels(preview_m: Sequence[float]) -> tuple[core.Channel, ...]:
    """The observation's course-relative numbers: progress along the course this episode (m),
    offset left of it (m), heading error to it (rad, left positive), the room left and right
    to its edges (m), and its curvature at each preview distance ahead (1/m, left positive)."""
    b = COURSE_BOUND
    return (core.Channel("progress_m", -b, b), core.Channel("lateral_m", -b, b),
            core.Channel("heading_error_rad", -math.pi, math.pi),
            core.Channel("room_left_m", -b, b), core.Channel("room_right_m", -b, b),
            *(core.Channel(f"curvature_{d:g}m_ahead_per_m", -b, b) for d in preview_m))


class CourseFrame:
    """Where a robot is relative to the world's course, step by step (progress accumulated
    over the steps, so a loop's laps add up)."""

    def __init__(self, course: Course, preview_m: Sequence[float]) -> None:
        self.course, self.preview_m = course, tuple(preview_m)
        self.length_m = course.length_m()
        self._raw: float | None = None
        self.progress = 0.0

    def locate(self, x: float, y: float, yaw: float) -> tuple[float, ...]:
        """The course channels at pose (x, y, yaw); the first call starts progress at 0."""
        xy = np.array([[x, y]])
        raw = float(self.course.progress_m(xy)[0])
        if self._raw is not None:
            step = raw - self._raw
            if self.course.closed:  # across the lap line
                step = (step + self.length_m / 2) % self.length_m - self.length_m / 2
            self.progress += step
        self._raw = raw
        lateral = float(self.course.offset_m(xy)[0])
        heading = self.course.pose_at(raw, 0.0)[2]
        error = (yaw - heading + math.pi) % (2 * math.pi) - math.pi
        right, left = self.course.room_m(raw)
        ahead = (self.course.curvature_at(raw + d) for d in self.preview_m)
        return (self.progress, lateral, error, min(left - lateral, COURSE_BOUND),
                min(right + lateral, COURSE_BOUND), *ahead)

    @staticmethod
    def off(values: Sequence[float]) -> bool:
        """Beyond the course's room on either side."""
        return float(values[3]) < 0.0 or float(values[4]) < 0.0


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

    Where the world has a course (a track, a line: `WorldKind.course`), the observation ends
    with the robot's place on it (`course_channels`: progress, offset, heading error, room to
    each edge, curvature at the kind's preview distances), read from the robot's odometry as
    its controller would, and the default reward is the step's progress along it (`progress_m`;
    `driven_m` without a course). The other agents keep their scenario controllers. The last
    step of an episode is shorter when `duration_s` is not a whole number of periods.

    An episode is `terminated` when every robot finished its course, when the robot touches
    anything but the floor, leaves the course's room (a track's edge) or loses control (its
    kind's `ControlSpace.lost`: a kart spinning, a line tracker's sensor seeing no line), and
    `truncated` when `duration_s` ran out; the last step's `info["ending"]` says which
    (`Ending`); `end_on` chooses among the first three. `reset(seed=s)` runs the
    scenario with `seed: s` (its noise); `reset()` runs the scenario's own seed first, then
    seeds drawn from the env's generator. Each episode is a new `Session` (a new PyBullet
    client, the last one closed first).

    Args:
        scenario: A scenario name or YAML path, or a loaded `Scenario`.
        agent: The agent the env drives (default: the scenario's first).
        log_dir: Where each episode's MCAP log goes (`episode-000001.mcap`, ...); at the end of
            an episode `info["log"]` names it and `info["metrics"]` holds its metrics, computed
            from the log by the same code as `kartci run`. None: no log.
        reward: `(previous observation, observation) -> float`; default `progress_m` (or
            `driven_m` in a world without a course).
        end_on: The endings besides finishing and running out of time that end an episode
            (`Ending` or its value); default: a collision, leaving the course, loss of control.
        overrides: `dotted.key=value` assignments, as `kartci.run` and `--set` take them.
        **values: Top-level scenario values as keywords (`duration_s=5`), applied after
            `overrides`.
    """

    metadata = {"render_modes": []}  # noqa: RUF012  (Env declares it an instance attribute)

    def __init__(self, scenario: str | Path | Scenario, *, agent: str | None = None,
                 log_dir: str | Path | None = None, reward: Reward | None = None,
                 render_mode: str | None = None, overrides: Sequence[str] = (),
                 end_on: Iterable[Ending | str] = TERMINAL, **values: object) -> None:
        if render_mode is not None:
            raise SpecError(f"kartci.gym: render_mode {render_mode!r}: kartci renders nothing "
                            "live; open the episode's log (log_dir) in Foxglove")
        sets = [*overrides, *override_strings(values)]
        proj = project.current()  # an entry point (gymnasium.make), as kartci.api
        if not isinstance(scenario, Scenario):
            scenario = load_scenario(scenario, sets, project=proj)
        elif sets:
            scenario = load_scenario(scenario.name, sets, project=proj)
        else:
            scenario = in_project(scenario, proj)
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
        make_course = core.WORLDS.get(scenario.world.kind).course
        self.course = make_course(scenario.world) if make_course is not None else None
        channels = (*self.space.observation,
                    *(course_channels(self.space.preview_m) if self.course else ()))
        self.action_names = tuple(c.name for c in self.space.command)
        self.observation_names = tuple(c.name for c in channels)
        self.action_box, self.observation_box = _box(self.space.command), _box(channels)
        self.action_space, self.observation_space = self.action_box, self.observation_box
        self.log_dir = None if log_dir is None else Path(log_dir)
        self.reward_fn = reward or progress_m(self.observation_names)
        try:
            self.end_on = frozenset(Ending(e) for e in end_on)
        except ValueError as err:
            raise SpecError(f"kartci.gym: end_on: {err}; one of "
                            f"{', '.join(e.value for e in TERMINAL)}") from None
        self._frame: CourseFrame | None = None
        self._body: int | None = None
        self.episodes = 0
        self._session: Session | None = None
        self._listener: _Listener | None = None
        self._obs: Observation | None = None
        self._raw: tuple[float, ...] | None = None  # the observation's values, unclipped
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
        self._frame = CourseFrame(self.course, self.space.preview_m) if self.course else None
        world = self._session.world
        self._body = next((b for b, n in world.names.items() if n == self.agent), None)
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
        ending = self._ending(r)
        if ending is not None:
            info["ending"] = ending
            self._end(info)  # before the run's end: its log is written as a shorter run's
        return (self._obs.copy(), reward, ending not in (None, Ending.TIME),
                ending is Ending.TIME, info)

    def _ending(self, r: StepResult) -> Ending | None:
        """Why the episode ends at this step, if it does."""
        if r.done and r.finished_course:
            return Ending.FINISHED
        raw, n = self._raw, len(self.space.observation)
        assert raw is not None
        ends = self.end_on
        if Ending.COLLISION in ends and self._touching():
            return Ending.COLLISION
        if Ending.OFF_COURSE in ends and self._frame is not None and CourseFrame.off(raw[n:]):
            return Ending.OFF_COURSE
        if Ending.LOST_CONTROL in ends and self.space.lost is not None and self.space.lost(
                dict(zip(self.observation_names, raw, strict=True))):
            return Ending.LOST_CONTROL
        return Ending.TIME if r.done else None

    def _touching(self) -> bool:
        """The robot's body touches anything but the floor (PyBullet's contacts now)."""
        if self._session is None or self._body is None:
            return False
        world = self._session.world
        return any(c[2] not in (world.floor, self._body) for c in pb.getContactPoints(
            bodyA=self._body, physicsClientId=world.client))

    def _observe(self) -> Observation:
        assert self._listener is not None
        values = tuple(float(v) for v in self.space.read(self._listener.latest))
        if self._frame is not None:
            x, y, yaw = values[:3]  # every kind's observation starts with odometry's pose
            values = (*values, *self._frame.locate(x, y, yaw))
        self._raw = values
        return np.clip(np.asarray(values, dtype=np.float32), self.observation_box.low,
                       self.observation_box.high)

    def _info(self, r: StepResult, seed: int) -> dict[str, Any]:
        return {"t_s": r.t_s, "step": r.step, "seed": seed}

    def _end(self, info: dict[str, Any]) -> None:
        """Close the episode's run (writing its log) and score the log."""
        s = self._session
        assert s is not None
        s.close()
        self._session = None
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
