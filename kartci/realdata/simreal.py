"""`kartci simreal`: a log's commands replayed into the simulated robot, whole and in windows,
recorded next to the log's own odometry in one run log, scored and reported like a run."""

from __future__ import annotations

import json
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kartci import core
from kartci.core import SimReal
from kartci.errors import SpecError
from kartci.logs import SCENARIO_TOPIC, McapLogWriter, messages, msg, open_log
from kartci.logs.types import for_writing
from kartci.project import Project
from kartci.realdata.divergence import SIM_WHOLE, SIM_WINDOWS, run_whole, run_windows
from kartci.realdata.drive import Drive, read_drive
from kartci.realdata.importer import _odom, import_log, imported_scenario
from kartci.realdata.plant import Converter, Plant, as_recorded, diff_drive
from kartci.realdata.profile import Profile
from kartci.scenario import Scenario, load_scenario
from kartci.scenario.dispatch import context

TWIST = ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped")
# what a log's commands may be when the robot's kind says nothing (`RobotKind.simreal`): the
# standard drive commands and the source document's KartCommand, applied as recorded
AS_RECORDED = (*TWIST, "ackermann_msgs/msg/AckermannDriveStamped",
               "kartci_msgs/msg/KartCommand")


def kind_simreal(kind: object) -> SimReal | None:
    """What a robot kind says about replaying its logs (None: not a registered kind's name, or
    it says nothing)."""
    if not isinstance(kind, str) or kind not in core.ROBOTS.names():
        return None
    return core.ROBOTS.get(kind).simreal


@dataclass(frozen=True)
class SimSetup:
    """The scenario simulated against a log, its overrides and the command conversion;
    `picked`: why that scenario, when it was guessed from the log (one line), else empty."""

    scenario: Scenario
    overrides: tuple[str, ...]
    convert: Converter
    picked: str = ""


_NAME_IT = "give --scenario, or `robot: {kind: ...}` or `scenario:` in a profile"


def guess_scenario(profile: Profile, types: dict[str, str]) -> tuple[str, str]:
    """The scenario for a log nobody named one for, and why, in one line: the robot kind
    replayed from the log's command type (RobotKind.simreal); of several, the one that turns a
    velocity command into wheel speeds (a Twist is what a differential-drive base takes). A
    SpecError when the log does not tell."""
    got = types.get("commands")
    if profile.commands is None or got is None:
        raise SpecError(f"profile {profile.name}: cannot tell which robot to simulate: the log "
                        f"has no single command topic to replay; {_NAME_IT}")
    fits = {n: r for n in core.ROBOTS.names()
            if (r := core.ROBOTS.get(n).simreal) is not None and got in r.commands}
    if len(fits) > 1 and got in TWIST:
        fits = {n: r for n, r in fits.items() if r.wheel_speeds} or fits
    topic = profile.commands.topic
    if len(fits) != 1:
        which = (f"{', '.join(sorted(fits))} are all replayed from it" if fits
                 else "no robot kind is replayed from it")
        raise SpecError(f"profile {profile.name}: cannot tell which robot to simulate: the "
                        f"commands {topic} are {got}, and {which}; {_NAME_IT}")
    (kind, replay), = fits.items()
    why = ("velocity commands a differential-drive base turns into wheel speeds"
           if replay.wheel_speeds and got in TWIST else f"commands only {kind} is replayed from")
    return replay.scenario, (f"simulating {replay.scenario} (robot kind {kind}): the commands "
                             f"{topic} are {got}, {why} (--scenario to choose another)")


def sim_setup(profile: Profile, scenario: str | None, overrides: Sequence[str], proj: Project,
              types: dict[str, str] | None = None) -> SimSetup:
    """The scenario to simulate (given, else the profile's, else by the profile's robot kind,
    else guessed from the log's command type `types["commands"]` when `types` is given), with
    the profile's robot parameters and then `overrides` (`--set`, calibrated values)."""
    kind = (profile.robot or {}).get("kind")
    default = kind_simreal(kind)
    name = scenario or profile.scenario or (default.scenario if default else None)
    picked = ""
    if name is None and types is not None:
        name, picked = guess_scenario(profile, types)
    if name is None:
        raise SpecError(f"profile {profile.name}: no scenario to simulate the log in; "
                        f"{_NAME_IT}")
    base = load_scenario(name, project=proj)
    if len(base.agents) != 1:
        raise SpecError(f"scenario {base.name}: simreal needs exactly one agent")
    agent = next(iter(base.agents))
    if kind is not None and kind != base.agents[agent].model.kind:
        raise SpecError(f"profile {profile.name}: robot kind {kind} but scenario {base.name} "
                        f"simulates {base.agents[agent].model.kind}")
    sets = [f"agents.{agent}.model.{key}={json.dumps(value)}"
            for key, value in (profile.robot or {}).items() if key != "kind"]
    sets += list(overrides)
    spec = load_scenario(name, sets, project=proj)
    model_kind = spec.agents[agent].model.kind
    if profile.commands is None:
        raise SpecError(f"profile {profile.name}: names no commands topic to replay")
    replay = kind_simreal(model_kind)
    wheels = replay is not None and replay.wheel_speeds
    convert = diff_drive(profile.commands) if wheels else as_recorded
    return SimSetup(spec, tuple(sets), convert, picked)


def check_commands(setup: SimSetup, profile: Profile, types: dict[str, str]) -> None:
    """The log's commands must be a type the simulated robot is driven by, as its kind says
    (Joy goes through `kartci replay` and its joystick mapping instead)."""
    kind = next(iter(setup.scenario.agents.values())).model.kind
    replay = kind_simreal(kind)
    usable = replay.commands if replay is not None else AS_RECORDED
    got = types.get("commands")
    if got not in usable:
        raise SpecError(f"profile {profile.name}: commands are {got}; a {kind} is replayed from "
                        f"{' or '.join(usable)}")


def simulate(setup: SimSetup, drive: Drive, window_s: float) -> dict[str, Any]:
    """The windowed and the whole-log sim runs: {"windows": (t, states), "whole": ...}."""
    plant = Plant(setup.scenario, drive, setup.convert)
    try:
        return {"windows": run_windows(plant, drive, window_s), "whole": run_whole(plant, drive)}
    finally:
        plant.close()


def simreal_log(log: Path, profile: Profile, types: dict[str, str], setup: SimSetup,
                window_s: float, dst: Path) -> Scenario:
    """Write `dst`: the imported log plus the sim's odometry (windowed and whole), and a
    recorded scenario whose `simreal` metrics score the divergence."""
    with tempfile.TemporaryDirectory() as tmp:
        imported = Path(tmp) / "imported.mcap"
        import_log(log, profile, types, imported)
        drive = read_drive(imported, profile.agent)
        runs = simulate(setup, drive, window_s)
        scenario = _scenario(profile, drive, setup, window_s)
        _write(imported, dst, scenario, profile.agent, drive, runs)
    return scenario


def _scenario(profile: Profile, drive: Drive, setup: SimSetup, window_s: float) -> Scenario:
    base = imported_scenario(profile, drive.duration_s)
    data = base.model_dump(mode="json")
    data["name"] = f"{profile.name}_simreal"
    data["description"] = f"sim vs log: {setup.scenario.name} driven by {profile.name}'s commands"
    data["metrics"]["simreal"] = {"window_s": window_s, "scenario": setup.scenario.name,
                                  "overrides": list(setup.overrides)}
    return Scenario.model_validate(data, context=context(core.DEFAULT_REGISTRIES))


def _write(imported: Path, dst: Path, scenario: Scenario, agent: str, drive: Drive,
           runs: dict[str, Any]) -> None:
    with open_log(imported) as reader:
        store = for_writing(reader.typestore)
    with McapLogWriter(dst, store) as out:
        for topic, t_ns, m in messages(imported):
            if topic == SCENARIO_TOPIC:
                m = msg("std_msgs/msg/String", data=scenario.model_dump_json())
            out.write(topic, m, t_ns)
        stamp0 = _first_stamp(imported, agent)
        for name, topic in (("windows", SIM_WINDOWS), ("whole", SIM_WHOLE)):
            t, states = runs[name]
            for ti, s in zip(t, states, strict=True):
                t_ns = stamp0 + round(float(ti) * 1e9)
                quat = (0.0, 0.0, float(np.sin(s[2] / 2)), float(np.cos(s[2] / 2)))
                out.write(f"/{agent}/{topic}", _odom(t_ns, "map", (s[0], s[1], 0.0), quat,
                                                      (s[3], s[4], 0.0, 0.0, 0.0, s[5])),
                          t_ns)


def _first_stamp(imported: Path, agent: str) -> int:
    for _, _, m in messages(imported, [f"/{agent}/odom"]):
        return int(m.header.stamp.sec) * 1_000_000_000 + int(m.header.stamp.nanosec)
    return 0
