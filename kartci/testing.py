"""`check_kind`: the checker a plugin author runs on what they register, as Gymnasium's
`utils.env_checker.check_env` is run on an environment.

It checks each robot kind, world kind, controller and metric set against its contract (typed
parameters whose tag is its name, the metric sets and robots it names registered, what a robot
kind declares of its messages, outline, odometry and control space), then builds, resets,
steps and scores a scenario that uses them, twice: reset at step 0, every step moving on by
one with its messages on absolute topics, every metric defined by its set with the set's unit,
the two runs' metrics equal (one seed, one result; wall-clock timings aside), and the robot
kind's plots and figures drawn from the log. Each failure is a
`KindCheckError` naming the part and what is wrong.

```python
from kartci.testing import check_kind

def test_my_kind() -> None:
    check_kind("my_scenario", robot="my_robot", metrics=("my_metrics",))
```
"""

from __future__ import annotations

import math
import re
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from kartci import core, project
from kartci.core import Controller, MetricDef, MetricSet, RobotKind, WorldKind
from kartci.errors import KartciError
from kartci.logs import tables
from kartci.logs.types import typestore
from kartci.metrics import compute, metric_sets
from kartci.plotting import Figure, FigureContext, PlotContext, Plots
from kartci.plotting.builders import events
from kartci.project import Project
from kartci.scenario import Scenario, in_project, load_scenario
from kartci.sim.session import Session

MSGTYPE = re.compile(r"^[A-Za-z0-9_]+/msg/[A-Za-z0-9_]+$")


class KindCheckError(KartciError, AssertionError):
    """A registered part breaks its contract; the message names the part and the fault."""


@dataclass
class Checked:
    """What `check_kind` checked, one line each (for a test to assert on, or to print)."""

    lines: list[str] = field(default_factory=list)

    def add(self, line: str) -> None:
        """Record one check that passed."""
        self.lines.append(line)


def _fail(what: str, fault: str) -> KindCheckError:
    return KindCheckError(f"{what}: {fault}")


def _is_a(what: str, item: object, contract: type) -> None:
    if not isinstance(item, contract):
        raise _fail(what, f"is a {type(item).__name__}, not a kartci.core.{contract.__name__}")


def _extends(what: str, params: type, base: type) -> None:
    if not issubclass(params, base):
        raise _fail(what, f"params {params.__name__} does not extend kartci.core.{base.__name__}")


def _tag_of(params: type[BaseModel], key: str) -> Any:
    prop = params.model_json_schema().get("properties", {}).get(key, {})
    return prop.get("const", prop.get("default"))


def check_robot(kind: RobotKind, checked: Checked | None = None) -> Checked:
    """A robot kind's contract, without running it."""
    out = checked or Checked()
    what = f"robot kind '{getattr(kind, 'name', kind)}'"
    _is_a(what, kind, RobotKind)
    _extends(what, kind.params, core.RobotParams)
    if _tag_of(kind.params, "kind") not in (kind.name, None):
        raise _fail(what, f"params {kind.params.__name__}.kind is "
                    f"{_tag_of(kind.params, 'kind')!r}, not the kind's name {kind.name!r}")
    if not callable(kind.factory):
        raise _fail(what, "factory is not callable")
    for name in kind.metrics:
        mset = core.METRICS.get(name)
        if mset.robots and kind.name not in mset.robots:
            raise _fail(what, f"names metric set '{name}', which applies to "
                        f"{', '.join(mset.robots)} only")
    _check_messages(what, kind)
    try:
        model = kind.params.model_validate({"kind": kind.name})
    except ValidationError:
        model = None  # a kind whose model needs values of its own: checked when it runs
    if model is not None:
        _check_model_parts(what, kind, model)
    out.add(f"{what}: contract")
    return out


def _check_messages(what: str, kind: RobotKind) -> None:
    """What a kind declares of its messages: flatteners, wall-clock fields, command types."""
    store = typestore()
    for msgtype, flat in kind.flatteners.items():
        if not MSGTYPE.match(msgtype) or not callable(flat):
            raise _fail(what, f"flatteners: {msgtype!r} must map a message type "
                        "(pkg/msg/Name) to a function of a message")
    for msgtype, names in {**kind.wall_clock}.items():
        try:
            fields = {f[0] for f in store.get_msgdef(msgtype).fields}
        except KeyError as err:
            raise _fail(what, f"wall_clock: {msgtype} is no message type kartci knows") from err
        if not set(names) <= fields:
            raise _fail(what, f"wall_clock: {msgtype} has no field "
                        f"{', '.join(sorted(set(names) - fields))}")
    for msgtype, topic in kind.commands.items():
        if topic not in kind.accepts:
            raise _fail(what, f"commands: {msgtype} is applied on '{topic}', which is not one "
                        f"of the topics it accepts ({', '.join(kind.accepts) or 'none'})")


def _check_model_parts(what: str, kind: RobotKind, model: Any) -> None:
    """What a kind derives from its default model: outline, odometry, control space."""
    if kind.outline is not None:
        outline = kind.outline(model, None)
        if not outline or any(len(p) < 3 or any(len(c) != 2 for c in p) for p in outline):
            raise _fail(what, "outline must be convex polygons of 3 or more (x, y) corners, "
                        f"got {outline!r}"[:300])
    if kind.odometry is not None:
        odo = kind.odometry(model)
        if not odo.joints or not odo.radius_m > 0:
            raise _fail(what, f"odometry names no wheel joints or no radius: {odo!r}")
    if kind.control is not None:
        space = kind.control(model)
        if space.topic not in kind.accepts:
            raise _fail(what, f"control: its command topic '{space.topic}' is not one of the "
                        f"topics it accepts ({', '.join(kind.accepts) or 'none'})")


def check_world(kind: WorldKind, checked: Checked | None = None) -> Checked:
    """A world kind's contract, without building it."""
    out = checked or Checked()
    what = f"world kind '{getattr(kind, 'name', kind)}'"
    _is_a(what, kind, WorldKind)
    _extends(what, kind.params, core.WorldParams)
    if _tag_of(kind.params, "kind") not in (kind.name, None):
        raise _fail(what, f"params {kind.params.__name__}.kind is not the kind's name")
    if not callable(kind.factory):
        raise _fail(what, "factory is not callable")
    out.add(f"{what}: contract")
    return out


def check_controller(ctl: Controller, checked: Checked | None = None) -> Checked:
    """A controller type's contract, without building one."""
    out = checked or Checked()
    what = f"controller '{getattr(ctl, 'name', ctl)}'"
    _is_a(what, ctl, Controller)
    _extends(what, ctl.params, core.ControllerParams)
    if _tag_of(ctl.params, "type") not in (ctl.name, None):
        raise _fail(what, f"params {ctl.params.__name__}.type is not the controller's name")
    period = ctl.params.model_fields["period_s"].default
    if not isinstance(period, float | int) or not period > 0:
        raise _fail(what, f"params {ctl.params.__name__}.period_s needs a default > 0")
    known = core.ROBOTS.names()
    if unknown := [r for r in ctl.robots if r not in known]:
        raise _fail(what, f"drives unregistered robot kinds: {', '.join(unknown)}")
    out.add(f"{what}: contract")
    return out


def check_metric_set(mset: MetricSet, checked: Checked | None = None) -> Checked:
    """A metric set's contract, without computing it."""
    out = checked or Checked()
    what = f"metric set '{getattr(mset, 'name', mset)}'"
    _is_a(what, mset, MetricSet)
    if not mset.defs:
        raise _fail(what, "defines no metric")
    shared = core.definitions()
    for name, d in mset.defs.items():
        if not isinstance(d, MetricDef) or not d.unit or not d.description:
            raise _fail(what, f"metric '{name}' needs a MetricDef with a unit and a "
                        "description")
        if shared.get(name, d) != d:
            raise _fail(what, f"metric '{name}' is defined differently by another set: one "
                        "name, one meaning")
    if mset.params is not None:
        _extends(what, mset.params, core.MetricParams)
        try:
            mset.params()
        except ValidationError as err:
            raise _fail(what, f"params {mset.params.__name__} needs a default for every "
                        f"field (a scenario may name the set without any): {err}") from err
    known = core.ROBOTS.names()
    if unknown := [r for r in mset.robots if r not in known]:
        raise _fail(what, f"applies to unregistered robot kinds: {', '.join(unknown)}")
    out.add(f"{what}: contract")
    return out


def check_kind(scenario: str | Path | Scenario | None = None, *, robot: str | None = None,
               world: str | None = None, controller: str | None = None,
               metrics: Sequence[str] = (), overrides: Sequence[str] = (),
               duration_s: float | None = None) -> Checked:
    """Check registered parts against their contracts and run them.

    Args:
        scenario: A scenario that uses the parts (name, YAML path or `Scenario`). Default:
            the first of the project's scenarios that uses every part named.
        robot, world, controller, metrics: The registered names to check; a scenario given
            alone has every part it names checked.
        overrides: `--set` assignments applied to the scenario.
        duration_s: How much sim time each of the two runs lasts (None: the scenario's own;
            shorter runs check faster, as long as its metric sets have samples to score).

    Returns:
        What was checked, one line each.

    Raises:
        KindCheckError: A part breaks its contract; the message names it and what is wrong.
        KartciError: The scenario cannot be loaded or run.
    """
    out = Checked()
    named = _parts(robot, world, controller, metrics)
    proj = project.current()  # an entry point for plugin authors, as kartci.api
    if scenario is None:
        scenario = _scenario_using(named, proj)
    sc = in_project(scenario, proj) if isinstance(scenario, Scenario) else load_scenario(
        scenario, [*overrides, *([f"duration_s={duration_s}"] if duration_s else [])],
        project=proj)
    if isinstance(scenario, Scenario) and duration_s:
        sc = sc.model_copy(update={"duration_s": min(sc.duration_s, duration_s)})
    uses = parts_of(sc)
    for key, names in named.items():
        if missing := [n for n in names if n not in uses[key]]:
            raise _fail(f"scenario '{sc.name}'", f"does not use {key} {', '.join(missing)}")
    for name in sorted(uses["robot"]):
        check_robot(core.ROBOTS.get(name), out)
    for name in sorted(uses["world"]):
        check_world(core.WORLDS.get(name), out)
    for name in sorted(uses["controller"]):
        check_controller(core.CONTROLLERS.get(name), out)
    for name in sorted(uses["metrics"]):
        check_metric_set(core.METRICS.get(name), out)
    with tempfile.TemporaryDirectory(prefix="kartci-check-") as tmp:
        first = _run_and_score(sc, Path(tmp) / "a.mcap", out)
        second = _run_and_score(sc, Path(tmp) / "b.mcap", None)
        defs = core.definitions()
        wall = {k for k in first if (d := defs.get(k.rpartition(".")[2])) and d.timing}
        if diff := [k for k in first if k not in wall and not _same(first[k], second.get(k))]:
            raise _fail(f"scenario '{sc.name}'", "two runs of one seed scored differently: "
                        + ", ".join(f"{k} {first[k]!r} then {second.get(k)!r}"
                                    for k in diff[:5]))
        out.add(f"scenario '{sc.name}': two runs score the same (wall-clock timings aside)")
        _check_figures(sc, Path(tmp) / "a.mcap", out)
    return out


def _parts(robot: str | None, world: str | None, controller: str | None,
           metrics: Sequence[str]) -> dict[str, list[str]]:
    """The parts named, each looked up (an unknown name is the registry's own error)."""
    named: dict[str, list[str]] = {"robot": [], "world": [], "controller": [], "metrics": []}
    for key, reg, name in (("robot", core.ROBOTS, robot), ("world", core.WORLDS, world),
                           ("controller", core.CONTROLLERS, controller)):
        if name is not None:
            reg.get(name)
            named[key].append(name)
    for name in metrics:
        core.METRICS.get(name)
        named["metrics"].append(name)
    return named


def parts_of(sc: Scenario) -> dict[str, set[str]]:
    """The registered parts a scenario names: robot kinds, world kind, controllers and the
    metric sets scored for its agents."""
    return {"robot": {a.model.kind for a in sc.agents.values()},
            "world": {sc.world.kind},
            "controller": {a.controller.type for a in sc.agents.values()},
            "metrics": {m.name for a in sc.agents for m in metric_sets(sc, a)}}


def _scenario_using(named: dict[str, list[str]], proj: Project) -> Scenario:
    """The first scenario of `proj` (its own, then kartci's) that uses every part."""
    if not any(named.values()):
        raise KindCheckError("check_kind: name a scenario or a part to check")
    for path in proj.all_scenarios():
        try:
            sc = load_scenario(path, project=proj)
        except KartciError:
            continue
        uses = parts_of(sc)
        if all(set(names) <= uses[key] for key, names in named.items()):
            return sc
    wanted = ", ".join(f"{k} {', '.join(v)}" for k, v in named.items() if v)
    raise KindCheckError(f"check_kind: no scenario of the project uses {wanted}; write one "
                         "and pass it as `scenario`")


def _run_and_score(sc: Scenario, log: Path, out: Checked | None) -> dict[str, Any]:
    """Build, reset and step the scenario to its end, checking each step; then score it."""
    steps = 0
    with Session(sc, log) as session:
        result = session.reset()
        if result.step != 0 or result.t_ns != 0:
            raise _fail(f"scenario '{sc.name}'", "reset() did not start at step 0, t = 0")
        while not result.done:
            k = result.step
            result = session.step()
            steps += 1
            if result.step != k + 1:
                raise _fail(f"scenario '{sc.name}'", f"step {k} moved to step {result.step}")
            if bad := [t for t, _ in result.messages if not t.startswith("/")]:
                raise _fail(f"scenario '{sc.name}'", f"a message on the relative topic "
                            f"'{bad[0]}' (topics are absolute once published)")
    if out is not None:
        out.add(f"scenario '{sc.name}': built, reset and stepped {steps} times")
    return _score(sc, log, out)


def _score(sc: Scenario, log: Path, out: Checked | None) -> dict[str, Any]:
    """Score a run's log; each metric defined by its set, with the set's unit."""
    _, scored = compute(log)
    many = len(sc.agents) > 1
    for agent in sc.agents:
        for mset in metric_sets(sc, agent):
            what = f"metric set '{mset.name}'"
            for key, metric in scored.items():
                owner, _, name = key.rpartition(".") if many else ("", "", key)
                if (many and owner != agent) or name not in mset.defs:
                    continue
                if metric.unit != mset.defs[name].unit:
                    raise _fail(what, f"metric '{name}' has unit '{metric.unit}' but its "
                                f"definition says '{mset.defs[name].unit}'")
    undefined = [k for k in scored if k.rpartition(".")[2] not in core.definitions()]
    if undefined:
        raise _fail(f"scenario '{sc.name}'", f"metrics without a definition in their set: "
                    f"{', '.join(undefined)}")
    if out is not None:
        out.add(f"scenario '{sc.name}': scored {len(scored)} metrics, each defined by its set")
    return {k: m.value for k, m in scored.items()}


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


def _check_figures(sc: Scenario, log: Path, out: Checked) -> None:
    """The kinds' plots and figures, drawn from the run's log."""
    for name in sorted({a.model.kind for a in sc.agents.values()}):
        kind = core.ROBOTS.get(name)
        what = f"robot kind '{name}'"
        if kind.plots is None:
            continue
        plots = kind.plots(PlotContext(sc, tables(log), log))
        if not isinstance(plots, Plots):
            raise _fail(what, f"plots returned a {type(plots).__name__}, not a "
                        "kartci.plotting.Plots")
        if kind.figures is None:
            out.add(f"{what}: plots drawn")
            continue
        figures = kind.figures(FigureContext(plots, events(plots)))
        for fig in figures:
            if not isinstance(fig, Figure):
                raise _fail(what, f"figures returned a {type(fig).__name__}, not a Figure")
            for s in fig.series:
                if len(s.x) != len(s.y):
                    raise _fail(what, f"figure '{fig.key}', series '{s.label}': "
                                f"{len(s.x)} x values but {len(s.y)} y values")
        out.add(f"{what}: plots and {len(figures)} figures drawn")


__all__ = ["Checked", "KindCheckError", "check_controller", "check_kind", "check_metric_set",
           "check_robot", "check_world", "parts_of"]
