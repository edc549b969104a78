"""Step one of scenario validation: the registered type names (`world.kind`, `model.kind`,
`controller.type`, the keys of `nodes` and of `metrics`) pick each part's own parameter model,
which then validates that part. A problem is a `ParamsError` that knows where in the file it is.

The registries are an argument, reaching the scenario's validator through pydantic's validation
context (`Scenario.model_validate(data, context=context(registries))`), not module globals."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, get_args, get_origin

from pydantic import BaseModel, ValidationError, ValidationInfo

from kartci import core
from kartci.errors import SpecError


class ParamsError(SpecError):
    """A part of a scenario failed its registered type's validation (or named no type)."""

    def __init__(self, loc: tuple[str | int, ...], errors: list[dict[str, Any]]) -> None:
        self.loc, self.errors = loc, errors
        first = errors[0]
        where = ".".join(str(p) for p in (*loc, *first.get("loc", ())))
        super().__init__(f"{where}: {first['msg']}")


def _validate(model: type[BaseModel], value: Any, loc: tuple[str | int, ...]) -> Any:
    if isinstance(value, model):
        return value
    try:
        return model.model_validate(value)
    except ValidationError as err:
        raise ParamsError(loc, with_allowed_keys(model, err)) from err


def with_allowed_keys(model: type[BaseModel], err: ValidationError) -> list[dict[str, Any]]:
    """The errors, each unknown key with the keys its model has (for a "did you mean")."""
    out: list[dict[str, Any]] = []
    for error in err.errors():
        e: dict[str, Any] = dict(error)
        if e["type"] == "extra_forbidden":
            owner: Any = model
            for part in e["loc"][:-1]:
                owner = _inner(owner, part)
            if isinstance(owner, type) and issubclass(owner, BaseModel):
                e["ctx"] = {"allowed": list(owner.model_fields)}
        out.append(e)
    return out


def _inner(owner: Any, part: str | int) -> Any:
    """The type one step down an error's location: a field of a model, the value type of a
    `dict[str, Model]` (an agent by name), the items of a list or tuple of one type (an index),
    the one type of an `X | None`; None when it cannot be told."""
    if isinstance(owner, type) and issubclass(owner, BaseModel):
        field = owner.model_fields.get(part) if isinstance(part, str) else None
        return field.annotation if field is not None else None
    args = [a for a in get_args(owner) if a is not type(None) and a is not Ellipsis]
    if get_origin(owner) in (dict, Mapping) and len(args) == 2:
        return args[1]
    if isinstance(part, int) and get_origin(owner) in (list, tuple):
        return args[0] if len(set(args)) == 1 else None
    if len(args) == 1:  # X | None
        return _inner(args[0], part)
    return None


def _tag(value: Any, key: str, loc: tuple[str | int, ...], what: str) -> str | None:
    """The registered name a mapping gives under `key`; None when the part is already built."""
    if isinstance(value, BaseModel):
        return None
    if not isinstance(value, dict):
        raise ParamsError(loc, [{"loc": (), "msg": f"expected a mapping with `{key}` naming "
                                 f"a {what}", "type": "model_type", "input": value}])
    tag = value.get(key)
    if not isinstance(tag, str):
        raise ParamsError(loc, [{"loc": (key,), "msg": f"required: the name of a registered "
                                 f"{what}", "type": "missing"}])
    return tag


def _named(registry: Any, tag: str, loc: tuple[str | int, ...]) -> Any:
    try:
        return registry.get(tag)
    except SpecError as err:
        raise ParamsError(loc, [{"loc": (), "msg": str(err), "type": "unknown_plugin",
                                 "input": tag}]) from err


CONTEXT_KEY = "registries"


def context(registries: core.Registries) -> dict[str, Any]:
    """The validation context a Scenario is validated with."""
    return {CONTEXT_KEY: registries}


def registries_of(info: ValidationInfo) -> core.Registries:
    """The registries a validator was handed; a TypeError (a caller's bug, not bad input)
    when it was handed none."""
    found = info.context.get(CONTEXT_KEY) if isinstance(info.context, dict) else None
    if not isinstance(found, core.Registries):
        raise TypeError("a Scenario is validated against registries in its validation context: "
                        "Scenario.model_validate(data, context=kartci.scenario.dispatch."
                        "context(kartci.core.DEFAULT_REGISTRIES)), or load it with "
                        "kartci.scenario.load_scenario")
    return found


def dispatch(data: Any, registries: core.Registries) -> Any:
    """A copy of raw scenario data with plugin-typed parts replaced by their parameter models
    (already-built parts are kept as they are), each type looked up in `registries`."""
    if not isinstance(data, dict):
        return data
    data = dict(data)
    world = data.get("world")
    tag = _tag(world, "kind", ("world",), "world kind") if "world" in data else None
    if tag is not None:
        kind = _named(registries.worlds, tag, ("world", "kind"))
        data["world"] = _validate(kind.params, world, ("world",))
    agents = data.get("agents")
    if isinstance(agents, dict):
        data["agents"] = {name: _agent(agent, ("agents", name), registries)
                          for name, agent in agents.items()}
    metrics = data.get("metrics")
    if isinstance(metrics, dict):
        built = {}
        for name, params in metrics.items():
            loc = ("metrics", str(name))
            mset = _named(registries.metrics, str(name), loc)
            if mset.params is None:
                if params not in (None, {}):
                    raise ParamsError(loc, [{"loc": (), "msg": f"metric set {name} takes no "
                                             "parameters", "type": "extra_forbidden"}])
                built[name] = core.MetricParams()
            else:
                built[name] = _validate(mset.params, params or {}, loc)
        data["metrics"] = built
    return data


def _agent(agent: Any, loc: tuple[str | int, ...], registries: core.Registries) -> Any:
    if not isinstance(agent, dict):
        return agent
    agent = dict(agent)
    model, controller = agent.get("model"), agent.get("controller")
    if "model" in agent:
        tag = _tag(model, "kind", (*loc, "model"), "robot kind")
        if tag is not None:
            kind = _named(registries.robots, tag, (*loc, "model", "kind"))
            agent["model"] = _validate(kind.params, model, (*loc, "model"))
            sensors = agent.get("sensors") or {}
            if kind.sensors is not None:
                agent["sensors"] = _validate(kind.sensors, sensors, (*loc, "sensors"))
            elif sensors:
                raise ParamsError((*loc, "sensors"), [{"loc": (), "msg": f"robot kind {tag} "
                                                       "has no sensors to set",
                                                       "type": "extra_forbidden"}])
    if "controller" in agent:
        tag = _tag(controller, "type", (*loc, "controller"), "controller")
        if tag is not None:
            ctl = _named(registries.controllers, tag, (*loc, "controller", "type"))
            agent["controller"] = _validate(ctl.params, controller, (*loc, "controller"))
    if isinstance(agent.get("nodes"), dict):
        agent["nodes"] = {str(name): _validate(_named(registries.nodes, str(name),
                                                      (*loc, "nodes", str(name))).params,
                                               params or {}, (*loc, "nodes", str(name)))
                          for name, params in agent["nodes"].items()}
    return agent
