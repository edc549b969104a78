"""The JSON Schema of a scenario file, built from the registries.

Every registered world kind, robot kind, controller and metric set contributes its own pydantic
parameter model, so a team's plugins (entry points, or the project's `plugins` list) appear in
the schema exactly like kartci's built-ins. Editors use it for completion, hover text and
validation: `kartci schema --out .kartci/scenario.schema.json`, then a first line
`# yaml-language-server: $schema=../.kartci/scenario.schema.json` in each scenario file.

The schema is a superset of what loading accepts where loading reads files: `world:` and
`agents.*.model:` may name a world or model file by string, which only loading can resolve.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

from pydantic import BaseModel
from pydantic.json_schema import models_json_schema

import kartci
from kartci import core
from kartci.atomic import check_target, write_text_atomic
from kartci.errors import SpecError
from kartci.scenario.models import Scenario

DIALECT = "https://json-schema.org/draft/2020-12/schema"
# A placeholder host: `.invalid` never resolves (RFC 2606). kartci uses no network; the id
# only names the schema and its kartci version for editors and their caches.
ID_TEMPLATE = "https://kartci.invalid/schema/scenario-{version}.json"

DEFS = "#/$defs/"


def scenario_schema(registries: core.Registries = core.DEFAULT_REGISTRIES) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a scenario file with every plugin in `registries`."""
    worlds, robots = registries.worlds.all(), registries.robots.all()
    controllers, metric_sets = registries.controllers.all(), registries.metrics.all()
    nodes = registries.nodes.all()
    models: list[type[BaseModel]] = [Scenario]
    models += [w.params for w in worlds]
    models += [r.params for r in robots]
    models += [r.sensors for r in robots if r.sensors is not None]
    models += [c.params for c in controllers]
    models += [n.params for n in nodes]
    models += [m.params for m in metric_sets if m.params is not None]
    models = list(dict.fromkeys(models))  # a model used by two plugins appears once
    refs, collected = models_json_schema([(m, "validation") for m in models],
                                         ref_template=DEFS + "{model}")

    def ref(model: type[BaseModel]) -> str:
        return str(refs[(model, "validation")]["$ref"])

    defs: dict[str, Any] = collected["$defs"]
    root = defs.pop(_name(ref(Scenario)))
    props = root["properties"]
    props["world"] = _world(props["world"]["description"], worlds, ref, defs)
    agent = defs[_name(props["agents"]["additionalProperties"]["$ref"])]["properties"]
    agent["model"] = _robot_model(agent["model"]["description"], robots, ref, defs)
    agent["controller"] = _controller(agent["controller"]["description"], controllers, ref)
    agent["sensors"] = _sensors(agent["sensors"]["description"], robots, ref)
    agent["nodes"] = _nodes(agent["nodes"]["description"], nodes, ref)
    props["metrics"] = _metrics(props["metrics"]["description"], metric_sets, ref)
    criteria = props["criteria"]
    props["criteria"] = _criteria(criteria["description"],
                                  criteria["additionalProperties"]["$ref"], registries.metrics)
    root["required"] = [r for r in root.get("required", []) if r != "name"]  # default: stem
    root["title"] = "kartci scenario"
    schema = {"$schema": DIALECT, "$id": ID_TEMPLATE.format(version=kartci.__version__),
              "$comment": f"written by `kartci schema` (kartci {kartci.__version__}) from the "
              "registered controllers, robot kinds, world kinds and metric sets; the $id's "
              "host is a placeholder (.invalid): nothing is fetched",
              **root, "$defs": defs}
    used = _used(schema)
    schema["$defs"] = {k: v for k, v in defs.items() if k in used}
    return schema


def write_schema(path: Path) -> None:
    """Write the schema to `path` (folders made as needed; atomic: a temporary file, then
    rename)."""
    check_target(path)
    text = json.dumps(scenario_schema(), indent=2) + "\n"
    try:
        write_text_atomic(path, text)
    except OSError as err:
        raise SpecError(f"{path}: cannot write the schema ({err.strerror or err})") from err


# --- the plugin-typed parts ----------------------------------------------------------------


def _name(ref: str) -> str:
    return ref.removeprefix(DEFS)


def _tagged(ref: str, tag: str, name: str, description: str) -> dict[str, Any]:
    """One registered plugin's parameters. Its name under `tag` is required and picks it, even
    when a plugin's own model types `tag` as any string."""
    return {"$ref": ref, "required": [tag], "description": description,
            "properties": {tag: {"const": name, "description": f"`{name}`"}}}


def _world(description: str, worlds: list[core.WorldKind], ref: Any,
           defs: dict[str, Any]) -> dict[str, Any]:
    kinds = [_tagged(ref(w.params), "kind", w.name, f"world kind `{w.name}`: {w.description}")
             for w in worlds]
    from_file: list[dict[str, Any]] = []
    for w in worlds:  # `{from: NAME, KEY: value}`: a world file with some keys replaced
        params = copy.deepcopy(defs[_name(ref(w.params))].get("properties", {}))
        from_file.append({
            "type": "object", "required": ["from"], "additionalProperties": False,
            "description": f"a `{w.name}` world file with some keys replaced",
            "properties": {"from": {"type": "string", "description": "the world file's name "
                                    "on the project's world path, e.g. `winti/hall`"},
                           **params}})
    return {"description": description, "anyOf": [
        {"type": "string", "description": "a world file's name on the project's world path "
         "(`<name>.yaml` in a world folder, e.g. `winti/hall`, `line_lab/straight`)"},
        {"anyOf": from_file, "description": "`{from: NAME, ...}`: a world file's contents with "
         "the keys given here replaced"},
        {"oneOf": kinds, "description": "a world in full, its kind named by `kind`"},
    ]}


def _robot_model(description: str, robots: list[core.RobotKind], ref: Any,
                 defs: dict[str, Any]) -> dict[str, Any]:
    kinds = [_tagged(ref(r.params), "kind", r.name, f"robot kind `{r.name}`: {r.description}")
             for r in robots]
    from_folder = [{  # `{from: NAME, KEY: value}`: a model folder's parameters, some replaced
        "type": "object", "required": ["from"], "additionalProperties": False,
        "description": f"a `{r.name}` model folder with some keys replaced",
        "properties": {"from": {"type": "string", "description": "the model folder's name on "
                                "the project's model path (`<name>/params.yaml`)"},
                       **copy.deepcopy(defs[_name(ref(r.params))].get("properties", {}))}}
        for r in robots]
    return {"description": description, "anyOf": [
        {"type": "string", "description": "a robot model folder's name on the project's "
         "model path (`<name>/params.yaml`)"},
        {"anyOf": from_folder, "description": "`{from: NAME, ...}`: a model folder's "
         "parameters with the keys given here replaced"},
        {"oneOf": kinds, "description": "a robot in full, its kind named by `kind`"},
    ]}


def _controller(description: str, controllers: list[core.Controller],
                ref: Any) -> dict[str, Any]:
    def says(c: core.Controller) -> str:
        robots = f" (drives {', '.join(c.kinds())})" if c.kinds() else ""
        return f"controller `{c.name}`: {c.description}{robots}"

    return {"description": description,
            "oneOf": [_tagged(ref(c.params), "type", c.name, says(c)) for c in controllers]}


def _sensors(description: str, robots: list[core.RobotKind], ref: Any) -> dict[str, Any]:
    """Each robot kind's sensor model; which one applies depends on the robot's kind, which a
    model folder only names when loaded, so any of them (or none) is accepted here."""
    options: list[dict[str, Any]] = [
        {"$ref": ref(r.sensors), "description": f"sensors of a `{r.name}` robot"}
        for r in robots if r.sensors is not None]
    options.append({"type": "null", "description": "no sensor settings: the defaults"})
    if any(r.sensors is None for r in robots):
        options.append({"type": "object", "maxProperties": 0,
                        "description": "a robot kind without sensor settings"})
    return {"description": description, "anyOf": options}


def _metrics(description: str, metric_sets: list[core.MetricSet],
             ref: Any) -> dict[str, Any]:
    props: dict[str, Any] = {}
    for m in metric_sets:
        names = ", ".join(m.defs)
        robots = f"; for {', '.join(m.robots)} robots" if m.robots else ""
        says = f"metric set `{m.name}`: {m.description} ({names}{robots})"
        none = {"type": "null", "description": "the set with its default parameters"}
        if m.params is None:
            props[m.name] = {"description": f"{says}; takes no parameters", "anyOf": [
                {"type": "object", "maxProperties": 0, "description": "no parameters"}, none]}
        else:
            props[m.name] = {"description": says, "anyOf": [
                {"$ref": ref(m.params), "description": f"parameters of `{m.name}`"}, none]}
    return {"type": "object", "description": description, "properties": props,
            "additionalProperties": False}


def _nodes(description: str, nodes: list[core.Node], ref: Any) -> dict[str, Any]:
    props = {n.name: {"description": f"node `{n.name}`: {n.description}", "anyOf": [
        {"$ref": ref(n.params), "description": f"parameters of `{n.name}`"},
        {"type": "null", "description": "the node with its default parameters"}]}
        for n in nodes}
    return {"type": "object", "description": description, "properties": props,
            "additionalProperties": False}


def _criteria(description: str, criterion: str,
              metrics: core.Registry[core.MetricSet]) -> dict[str, Any]:
    """Known metric names as keys, each described with its unit and meaning; `agent.metric`
    for one agent of several."""
    props: dict[str, Any] = {}
    for name, d in sorted(core.definitions(metrics).items()):
        better = {"lower": "lower is better", "higher": "higher is better",
                  "equal": "must equal its baseline"}[d.direction.value]
        timing = "; wall-clock, machine-dependent" if d.timing else ""
        props[name] = {"$ref": criterion, "description": f"{name} [{d.unit}]: {d.description} "
                       f"({better}{timing})"}
    per_agent = {rf"^[^.]+\.{re.escape(name)}$": {**p, "description": "one agent's "
                                                  f"(AGENT.{name}) {p['description']}"}
                 for name, p in props.items()}
    return {"type": "object", "description": description, "properties": props,
            "patternProperties": per_agent, "additionalProperties": False}


def _used(schema: dict[str, Any]) -> set[str]:
    """Names of the $defs reachable from the schema's root (every other part dropped)."""
    defs = schema["$defs"]
    seen: set[str] = set()
    todo: list[Any] = [{k: v for k, v in schema.items() if k != "$defs"}]
    while todo:
        node = todo.pop()
        if isinstance(node, dict):
            target = node.get("$ref")
            if isinstance(target, str) and target.startswith(DEFS):
                name = _name(target)
                if name not in seen and name in defs:
                    seen.add(name)
                    todo.append(defs[name])
            todo.extend(node.values())
        elif isinstance(node, list):
            todo.extend(node)
    return seen
