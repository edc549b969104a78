"""Load scenario YAML, resolve world/model references, apply `--set` overrides, validate."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from kartci.errors import SpecError
from kartci.spec.models import Scenario
from kartci.spec.yamlio import clip, parse_value, preview, read_yaml


def project_root() -> Path:
    """The folder holding scenarios/, sims/, models/ and baselines/ (KARTCI_ROOT overrides)."""
    env = os.environ.get("KARTCI_ROOT")
    return Path(env) if env else Path(__file__).resolve().parents[2]


def scenario_dir() -> Path:
    return project_root() / "scenarios"


def scenario_names() -> list[str]:
    return sorted(p.stem for p in scenario_dir().glob("*.yaml"))


def _read_yaml(path: Path) -> dict[str, Any]:
    return read_yaml(path)


def scenario_path(name: str) -> Path:
    """A scenario by name (scenarios/NAME.yaml) or by path to a YAML file."""
    if name.endswith((".yaml", ".yml")) or "/" in name:
        return Path(name)
    path = scenario_dir() / f"{name}.yaml"
    if not path.exists():
        known = ", ".join(scenario_names()) or "none"
        raise SpecError(f"unknown scenario '{name}' (known: {known}); see `kartci list`")
    return path


def _resolve_refs(data: dict[str, Any], path: Path) -> None:
    root = project_root()
    world = data.get("world")
    if isinstance(world, str):
        data["world"] = _read_yaml(root / "sims" / f"{world}.yaml")
    elif isinstance(world, dict) and isinstance(world.get("from"), str):
        # `world: {from: winti/hall, obstacles: [...]}`: a sims file with keys replaced
        data["world"] = {**_read_yaml(root / "sims" / f"{world['from']}.yaml"),
                         **{k: v for k, v in world.items() if k != "from"}}
    agents = data.get("agents")
    if isinstance(agents, dict):
        for agent in agents.values():
            if isinstance(agent, dict) and isinstance(agent.get("model"), str):
                agent["model"] = _read_yaml(root / "models" / agent["model"] / "params.yaml")


def apply_override(data: dict[str, Any], assignment: str) -> None:
    """Apply one `dotted.key=value`; the value is parsed as YAML (numbers, booleans, lists)."""
    key, sep, raw = assignment.partition("=")
    if not sep or not key.strip():
        raise SpecError(f"--set {clip(repr(assignment), 80)}: expected dotted.key=value")
    parts = key.strip().split(".")
    key = clip(key, 80)  # for messages
    node: Any = data
    for i, part in enumerate(parts[:-1]):
        if not isinstance(node, dict):
            raise SpecError(f"--set {key}: '{clip('.'.join(parts[:i]), 80)}' is not a mapping")
        node = node.setdefault(part, {})
    if not isinstance(node, dict):
        raise SpecError(f"--set {key}: '{clip('.'.join(parts[:-1]), 80)}' is not a mapping")
    node[parts[-1]] = parse_value(raw, f"--set {key}")


def _one_line(err: ValidationError, path: Path, overrides: list[str]) -> str:
    first = err.errors()[0]
    loc = ".".join(str(p) for p in first["loc"] if not str(p).startswith(("function-", "tagged")))
    loc = clip(".".join(p for p in loc.split(".") if p not in ("straight", "circle", "line_pid")))
    source = " (from --set)" if any(o.split("=")[0].strip() == loc for o in overrides) else ""
    msg = clip(first["msg"])
    if first["type"] == "extra_forbidden":
        msg = "unknown key"
    elif first["type"] == "missing":
        msg = "required key is missing"
    got = first.get("input")
    shown = "" if first["type"] in ("missing", "extra_forbidden") or isinstance(got, dict) else (
        f" (got {preview(got, 60)})"
    )
    n = len(err.errors())
    more = f" [+{n - 1} more]" if n > 1 else ""
    return f"{path}: {loc or '<top>'}{source}: {msg}{shown}{more}"


def load_scenario(name: str, overrides: list[str] | None = None) -> Scenario:
    """Load and validate a scenario; every problem becomes one SpecError line."""
    overrides = overrides or []
    path = scenario_path(name)
    data = _read_yaml(path)
    data.setdefault("name", path.stem)
    _resolve_refs(data, path)
    for assignment in overrides:
        apply_override(data, assignment)
        _resolve_refs(data, path)  # `--set world=line_lab/circle` names a file too
    try:
        return Scenario.model_validate(data)
    except ValidationError as err:
        raise SpecError(_one_line(err, path, overrides)) from None
    except (ArithmeticError, RecursionError) as err:  # a validator's arithmetic on odd values
        raise SpecError(f"{path}: a value is out of range ({clip(str(err))})") from err


def scenario_from_json(text: str) -> Scenario:
    """Rebuild a resolved scenario from the JSON recorded in a run log."""
    try:
        return Scenario.model_validate_json(text)
    except ValidationError as err:
        raise SpecError(f"recorded scenario: {err.errors()[0]['msg']}") from None


def json_schema() -> dict[str, Any]:
    """JSON Schema of a scenario file; `world` and `model` may also name a file by string."""
    schema = Scenario.model_json_schema()
    props = schema["properties"]
    props["world"] = {"anyOf": [{"type": "string", "description": "sims/<name>.yaml"},
                                props["world"]]}
    agent = schema["$defs"]["AgentSpec"]["properties"]
    agent["model"] = {"anyOf": [{"type": "string", "description": "models/<name>/params.yaml"},
                                agent["model"]]}
    schema["required"] = [r for r in schema.get("required", []) if r != "name"]
    return schema
