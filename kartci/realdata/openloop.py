"""Open-loop sensor replay: a log's recorded inputs fed to a registered agent (a controller, a
localization, a detector), its outputs recorded next to the inputs and compared with a reference
log's outputs, exactly or within per-field tolerances (openpilot's process replay, for
kartci's agents)."""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from kartci import core
from kartci.core import AgentContext, RobotParams
from kartci.errors import LogError, SpecError
from kartci.logs import SCENARIO_TOPIC, McapLogWriter, messages, open_log, tables, topics
from kartci.logs.types import for_writing
from kartci.metrics import recorded_scenario
from kartci.realdata.builtin import RecordedRobot


def lookup(name: str) -> core.Node | core.Controller:
    """A registered node (localization, detector, a team's own) or controller, by name."""
    if name in core.NODES.names():
        return core.NODES.get(name)
    return core.CONTROLLERS.get(name)


def build_agent(name: str, log: Path, namespace: str | None) -> tuple[Any, str]:
    """The agent `name` for the log's robot `namespace` (default: the run log's first agent),
    with the log's recorded parameters when the log's scenario used the same type."""
    kind = lookup(name)
    params: Any = None
    model: RobotParams = RecordedRobot()
    info = topics(log)  # a missing or unreadable file is its own one-line error
    try:
        scenario = (recorded_scenario(tables(log, [SCENARIO_TOPIC]), log)
                    if any(i.topic == SCENARIO_TOPIC for i in info) else None)
    except LogError:
        scenario = None
    if scenario is not None:
        namespace = namespace or next(iter(scenario.agents))
        spec = scenario.agents.get(namespace)
        if spec is not None:
            model = spec.model
            if spec.controller.type == name:
                params = spec.controller
            params = spec.nodes.get(name, params)
    if namespace is None:
        listed = ", ".join(f"{i.topic} ({i.msgtype})" for i in info) or "none"
        raise SpecError(f"{log}: not a kartci run log (no {SCENARIO_TOPIC}); name the robot's "
                        f"namespace its {name} inputs are under (--ns); topics: {listed}")
    if params is None:
        params = _defaults(kind, name, log)
    ctx = AgentContext(namespace, model, ())
    if scenario is None and (kind.robots or kind.fits is not None):
        raise SpecError(f"{log}: {name} runs on {' or '.join(kind.kinds()) or 'no registered'} "
                        "robots, and a foreign log's robot is none of them (its kind is "
                        "`recorded`); `kartci localize` replays its lidar, IMU and odometry "
                        "through localization, `kartci score` judges its recorded streams")
    return kind.build(params, ctx), namespace


def _defaults(kind: core.Node | core.Controller, name: str, log: Path) -> Any:
    """The agent's parameters at their defaults: a log without kartci's scenario records none.
    An agent with a required parameter (the `commands` controller's `source`) cannot be built
    from such a log: a SpecError that says which, not pydantic's ValidationError."""
    try:
        return kind.params(type=name) if isinstance(kind, core.Controller) else kind.params()
    except ValidationError as err:
        fields = sorted({".".join(str(x) for x in e["loc"]) for e in err.errors()
                         if e["type"] == "missing"})
        what = (f"required parameters ({', '.join(fields)})" if fields
                else "parameters whose defaults do not validate")
        raise SpecError(f"{log}: --agent {name} has {what} that only a kartci run log of a "
                        f"scenario using {name} records; replay such a log, or choose an "
                        "agent whose parameters all have defaults") from err


@dataclass
class Mismatch:
    """Where one output topic differs from the reference."""

    topic: str
    compared: int
    differing: int = 0
    worst: dict[str, float] = field(default_factory=dict)  # field -> largest |difference|
    note: str = ""


def replay(agent: Any, namespace: str, log: Path, dst: Path) -> dict[str, int]:
    """Feed the log's messages on the agent's inputs to it, stepping it every `period_s` of log
    time; write the inputs and its outputs (in the namespace) to `dst`. Returns output counts."""
    full = {(t if t.startswith("/") else f"/{namespace}/{t}"): t for t in agent.inputs}
    with open_log(log) as reader:
        store = for_writing(reader.typestore)
        found = {i.topic for i in reader.topics()}
    missing = sorted(set(full) - found)
    if missing:
        raise SpecError(f"{log}: the agent reads {', '.join(missing)}, which the log lacks "
                        f"(it has {', '.join(sorted(found)) or 'no topics'})")
    period_ns = round(agent.period_s * 1e9)
    counts: dict[str, int] = {}
    with McapLogWriter(dst, store) as out:
        tick: int | None = None  # the next control tick: it runs after every message up to it
        last = 0
        for topic, t_ns, m in messages(log, sorted(full)):
            if tick is None:
                tick = t_ns - t_ns % period_ns
            while tick < t_ns:
                _step(agent, namespace, tick, out, counts)
                tick += period_ns
            out.write(topic, m, t_ns)
            agent.on_message(full[topic], m)
            last = t_ns
        while tick is not None and tick <= last:
            _step(agent, namespace, tick, out, counts)
            tick += period_ns
    return counts


def _step(agent: Any, ns: str, t_ns: int, out: McapLogWriter, counts: dict[str, int]) -> None:
    for topic, m in agent.step(t_ns):
        full = topic if topic.startswith("/") else f"/{ns}/{topic}"
        out.write(full, m, t_ns)
        counts[full] = counts.get(full, 0) + 1


def _fields(m: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """Leaf fields of a message by dotted name (arrays whole)."""
    slots = getattr(m, "__dataclass_fields__", None)
    if slots is None:
        yield prefix, m
        return
    for name in slots:
        if name == "__msgtype__":
            continue
        yield from _fields(getattr(m, name), f"{prefix}.{name}" if prefix else name)


def _difference(a: Any, b: Any) -> float:
    """|a - b| for numbers and arrays (largest element), 0/inf for anything else."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a_arr, b_arr = np.asarray(a), np.asarray(b)
        if a_arr.shape != b_arr.shape:
            return math.inf
        if a_arr.size == 0:
            return 0.0
        if a_arr.dtype.kind in "fiub" and b_arr.dtype.kind in "fiub":
            return float(np.max(np.abs(a_arr.astype(float) - b_arr.astype(float))))
        return 0.0 if np.array_equal(a_arr, b_arr) else math.inf
    if isinstance(a, int | float) and isinstance(b, int | float):
        return abs(float(a) - float(b))
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        if len(a) != len(b):
            return math.inf
        return max((_difference(x, y) for x, y in zip(a, b, strict=True)), default=0.0)
    return 0.0 if a == b else math.inf


def compare(outputs: Path, reference: Path, topics: list[str],
            tolerances: Mapping[str, float]) -> list[Mismatch]:
    """Each output topic of `outputs` against the same topic of `reference`, message by
    message in order, field by field: equal, or within the tolerance given for that field
    (`topic:field` or `field`, dotted; default 0, exact)."""
    out = []
    for topic in topics:
        mine = [m for _, _, m in messages(outputs, [topic])]
        ref = [m for _, _, m in messages(reference, [topic])]
        result = Mismatch(topic, min(len(mine), len(ref)))
        if len(mine) != len(ref):
            result.note = f"{len(mine)} messages, the reference has {len(ref)}"
        for a, b in zip(mine, ref, strict=False):
            bad = False
            for (name, va), (_, vb) in zip(_fields(a), _fields(b), strict=False):
                diff = _difference(va, vb)
                tol = tolerances.get(f"{topic}:{name}", tolerances.get(name, 0.0))
                if diff > tol:
                    bad = True
                    result.worst[name] = max(result.worst.get(name, 0.0), diff)
            result.differing += bad
        out.append(result)
    return out


def open_loop(log: Path, name: str, namespace: str | None, reference: Path | None,
              tolerances: Mapping[str, float], out: Path) -> list[Mismatch]:
    """Replay `log` through agent `name` into OUT/openloop.mcap and compare its outputs with
    `reference` (default: the log itself, which holds the outputs recorded when it ran)."""
    agent, ns = build_agent(name, log, namespace)
    dst = out / "openloop.mcap"
    out.mkdir(parents=True, exist_ok=True)
    counts = replay(agent, ns, log, dst)
    if not counts:
        raise LogError(f"{log}: agent {name} published nothing when fed the log's "
                       f"{', '.join(agent.inputs)}")
    return compare(dst, reference or log, sorted(counts), tolerances)
