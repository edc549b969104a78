"""Load scenario YAML, resolve world/model references, apply `--set` overrides, validate."""

from __future__ import annotations

import contextlib
import copy
import json
import os
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ValidationError

from kartci import core
from kartci.errors import KartciError, SpecError, did_you_mean
from kartci.project import Origin, Project, held
from kartci.scenario.dispatch import ParamsError, context, dispatch, with_allowed_keys
from kartci.scenario.models import Scenario, WorldParams, unit_of
from kartci.scenario.schema import scenario_schema
from kartci.scenario.yamlio import Mark, clip, parse_value, preview, read_yaml_marked

Marks = dict[str, Mark]  # dotted key -> where it was written (yamlio.read_yaml_marked)


def scenario_names(proj: Project) -> list[str]:
    """Every scenario reachable by name: the project's own, then the built-in ones."""
    return list(proj.all_scenarios())


@dataclass(frozen=True)
class ScenarioEntry:
    """One scenario reachable by name: its file, where it comes from, and its description or
    the one-line reason it cannot be loaded."""

    name: str
    path: Path
    origin: Origin
    description: str = ""
    error: str | None = None


def scenario_catalogue(proj: Project) -> list[ScenarioEntry]:
    """Every scenario reachable by name, each loaded and validated; a bad file is an entry
    with its error, not an exception, so one broken file hides no other."""
    out = []
    for name, path in proj.all_scenarios().items():
        origin = proj.origin_of(path)
        if path.is_symlink() and not path.exists():
            out.append(ScenarioEntry(name, path, origin,
                                     error=f"{path}: broken link (to {path.readlink()})"))
            continue
        try:
            spec = load_scenario(name, project=proj)
        except KartciError as err:
            out.append(ScenarioEntry(name, path, origin, error=str(err)))
        except Exception as err:  # a kartci bug: still one line, and the others are listed
            out.append(ScenarioEntry(name, path, origin, error=f"{path}: {type(err).__name__}: "
                                     f"{err} (a bug in kartci or a plugin)"))
        else:
            out.append(ScenarioEntry(name, path, origin, spec.description))
    return out


def _read_yaml(path: Path, marks: Marks, prefix: str = "", keep: tuple[str, ...] = ()
               ) -> dict[str, Any]:
    """A world, model or scenario file, its keys' marks grafted into `marks` under `prefix`
    (`world`, `agents.kart0.model`): the marks of what it replaces go, those of the keys in
    `keep` (given beside `from:` in the scenario) stay."""
    data, found = read_yaml_marked(path)
    if prefix:
        _forget(marks, prefix, keep)
        marks.update({f"{prefix}.{k}": m for k, m in found.items()
                      if k.partition(".")[0] not in keep})
    else:
        marks.update(found)
    return data


def _forget(marks: Marks, key: str, keep: tuple[str, ...] = ()) -> None:
    """Drop the marks of everything under `key` (a --set or a file replaced it), but `keep`."""
    for k in [k for k in marks if k.startswith(f"{key}.")
              and k[len(key) + 1:].partition(".")[0] not in keep]:
        del marks[k]


def scenario_path(name: str | Path, proj: Project) -> Path:
    """A scenario by name (on the project's scenario path) or by path to a YAML file."""
    if isinstance(name, Path) or name.endswith((".yaml", ".yml")) or "/" in name:
        return Path(name)
    return proj.find_scenario(name)


def _resolve_refs(data: dict[str, Any], path: Path, proj: Project, allow_outside: bool,
                  marks: Marks) -> None:
    """World and model names become their files' contents; data files named inside them become
    absolute paths found on the project's search path (never outside it, nor outside the
    project and kartci's data through an absolute path or a symlink, unless `allow_outside`)."""
    _resolve_world(data, proj, allow_outside, marks)
    agents = data.get("agents")
    if not isinstance(agents, dict):
        return
    for name, agent in agents.items():
        if isinstance(agent, dict):
            _resolve_agent(agent, proj, path, allow_outside, (marks, f"agents.{name}.model"))
            _check_urdf(agent, f"agents.{clip(str(name), 80)}", proj, allow_outside)


def _resolve_world(data: dict[str, Any], proj: Project, allow_outside: bool,
                   marks: Marks) -> None:
    """`world: <name>` or `world: {from: <name>, ...}` becomes the world file's keys (with those
    given replacing its own), and a relative track file its path on the search path."""
    world = data.get("world")
    if isinstance(world, str):
        data["world"] = _read_yaml(proj.find_world(world, allow_outside), marks, "world")
    elif isinstance(world, dict) and isinstance(world.get("from"), str):
        # `world: {from: winti/hall, obstacles: [...]}`: a world file with keys replaced
        given = {k: v for k, v in world.items() if k != "from"}
        data["world"] = {**_read_yaml(proj.find_world(world["from"], allow_outside), marks,
                                      "world", tuple(given)), **given}
    world = data.get("world")
    if isinstance(world, dict) and isinstance(world.get("track"), str):
        track = world["track"]
        if Path(track).is_absolute():
            proj.contained(Path(track), "world.track", allow_outside)
        else:
            with contextlib.suppress(SpecError):  # may be a command-line path: checked later
                world["track"] = str(proj.world_file(track, allow_outside))


def load_world(name: str, proj: Project,
               registries: core.Registries = core.DEFAULT_REGISTRIES) -> tuple[WorldParams, Path]:
    """A world file by name on `proj`'s search path (`winti/hall`), validated by its world
    kind (looked up in `registries`), and where the file is."""
    path = proj.find_world(name)
    data: dict[str, Any] = {"world": name}
    _resolve_world(data, proj, allow_outside=False, marks={})
    world = dispatch(data, registries)["world"]
    assert isinstance(world, WorldParams)  # dispatch validated it by its kind
    return world, path


def _resolve_agent(agent: dict[str, Any], proj: Project, path: Path,
                   allow_outside: bool, marked: tuple[Marks, str]) -> None:
    """`model: <name>` becomes the model's parameters (its URDF a path on the search path), and
    a controller's relative source log a path relative to the scenario file at `path`."""
    model = agent.get("model")
    given: dict[str, Any] = {}
    if isinstance(model, dict) and isinstance(model.get("from"), str):
        # `model: {from: NAME, wheel_time_constant_s: 0}`: a model folder's, with keys replaced
        given = {k: v for k, v in model.items() if k != "from"}
        model = model["from"]
    if isinstance(model, str):
        params = _read_yaml(proj.find_model(model, allow_outside), *marked, tuple(given))
        urdf = params.get("urdf")
        if isinstance(urdf, str) and not Path(urdf).is_absolute():
            params["urdf"] = str(proj.model_file(f"{model}/{urdf}", allow_outside))
        agent["model"] = {**params, **given}
    controller = agent.get("controller")
    source = controller.get("source") if isinstance(controller, dict) else None
    if isinstance(source, dict) and isinstance(source.get("log"), str):
        log = Path(source["log"])
        if not log.is_absolute():  # relative to the scenario file
            source["log"] = str((path.parent / log).resolve())


def _check_urdf(agent: dict[str, Any], where: str, proj: Project,
                allow_outside: bool) -> None:
    """An absolute URDF path (in a model file, inline, or from `--set`) must stay inside the
    project and kartci's data; a relative one is looked up on the model path when it runs."""
    model = agent.get("model")
    urdf = model.get("urdf") if isinstance(model, dict) else None
    if isinstance(urdf, str) and Path(urdf).is_absolute():
        proj.contained(Path(urdf), f"{where}.model.urdf", allow_outside)


def _resolve_command_line_paths(data: dict[str, Any], overrides: list[str], proj: Project,
                                allow_outside: bool) -> None:
    """A data path given with `--set` may name a file relative to the working directory, as a
    user typing it expects, inside the project or kartci's data (anywhere with
    `allow_outside`); one in a file must be on the project's search path."""
    keys = {o.partition("=")[0].strip() for o in overrides}
    world = data.get("world")
    if isinstance(world, dict) and isinstance(world.get("track"), str):
        track = Path(world["track"])
        if not track.is_absolute():
            if keys & {"world.track", "world"} and track.is_file():
                world["track"] = str(proj.contained(track, "world.track", allow_outside))
            else:  # raises: not on the search path
                proj.world_file(str(track), allow_outside)
    agents = data.get("agents")
    for name, agent in agents.items() if isinstance(agents, dict) else ():
        if isinstance(agent, dict):
            _check_run_time_files(agent, f"agents.{clip(str(name), 80)}", proj, allow_outside)


def _check_run_time_files(agent: dict[str, Any], where: str, proj: Project,
                          allow_outside: bool) -> None:
    """Files an agent reads when it runs (its controller's source log and joystick mapping,
    a node's map) become absolute paths checked here, where `allow_outside` is known, as
    world.track is: a worker then reads only what passed. A log typed on the command line
    (`kartci replay LOG`, `score`, `extract`) is the user's explicit choice and is not checked;
    it does not come through here."""
    controller = agent.get("controller")
    if isinstance(controller, dict):
        source = controller.get("source")
        if isinstance(source, dict) and isinstance(source.get("log"), str):
            # relative to the scenario file (made absolute by _resolve_agent) or, from --set,
            # to the working directory
            source["log"] = str(proj.contained(Path(source["log"]),
                                               f"{where}.controller.source.log", allow_outside))
        if isinstance(controller.get("mapping"), str):
            model = agent.get("model")
            kind = model.get("kind") if isinstance(model, dict) else None
            controller["mapping"] = _mapping(controller["mapping"], kind,
                                             f"{where}.controller.mapping", proj, allow_outside)
    nodes = agent.get("nodes")
    for node, params in nodes.items() if isinstance(nodes, dict) else ():
        if isinstance(params, dict) and isinstance(params.get("map"), str):
            # a node's map (the localization's PLY): on the world path, or absolute
            given = Path(params["map"])
            what = f"{where}.nodes.{clip(str(node), 80)}.map"
            params["map"] = str(proj.contained(given, what, allow_outside) if given.is_absolute()
                                else proj.world_file(str(given), allow_outside))


def _mapping(value: str, kind: Any, what: str, proj: Project,
             allow_outside: bool) -> str:
    """A joystick mapping given by path (ending in .yaml / .yml or holding a separator) as its
    absolute, checked path; a name stays a name (it reads better in `kartci show`), its file
    (`<kind>/joy/<name>.yaml` on the model path, where a robot kind keeps its mappings) checked
    for a link out."""
    if value.endswith((".yaml", ".yml")) or "/" in value or os.sep in value:
        return str(proj.contained(Path(value).expanduser(), what, allow_outside))
    if kind not in core.ROBOTS.names():
        return value  # not a robot kind: validation names the problem
    for folder in proj.model_path:
        for suffix in (".yaml", ".yml"):
            found = folder / kind / "joy" / f"{value}{suffix}"
            if found.is_file():
                proj.contained(found, what, allow_outside)
                return value
    return value  # unknown: the agent names the known mappings when it starts


def apply_override(data: dict[str, Any], assignment: str) -> None:
    """Apply one `dotted.key=value`; the value is parsed as YAML (numbers, booleans, lists). A
    number after a list is an index into it (`world.zones.0.friction`): that item must exist."""
    key, sep, raw = assignment.partition("=")
    if not sep or not key.strip():
        raise SpecError(f"--set {clip(repr(assignment), 80)}: expected dotted.key=value")
    parts = key.strip().split(".")
    key = clip(key, 80)  # for messages
    agents = data.get("agents")
    if len(parts) > 2 and parts[0] == "agents" and isinstance(agents, dict) and agents and (
            parts[1] not in agents):  # a key inside an agent the scenario does not have
        raise SpecError(f"--set {key}: unknown agent '{clip(parts[1], 80)}'"
                        f"{did_you_mean(parts[1], agents)}")
    node: Any = data
    for i in range(len(parts) - 1):
        node = _step(node, parts, i, key)
    where = f"--set {key}: '{clip('.'.join(parts[:-1]), 80)}'"
    if isinstance(node, list):
        node[_item_index(node, parts[-1], where)] = parse_value(raw, f"--set {key}")
    elif isinstance(node, dict):
        node[parts[-1]] = parse_value(raw, f"--set {key}")
    else:
        raise SpecError(f"{where} is not a mapping or a list")


def _step(node: Any, parts: list[str], i: int, key: str) -> Any:
    """Step `i` down a `--set` key: into a list's item, or a mapping's key (made if missing,
    unless an item index follows: no list is given there, so there is no item to set)."""
    where = f"--set {key}: '{clip('.'.join(parts[:i]), 80)}'"
    if isinstance(node, list):
        return node[_item_index(node, parts[i], where)]
    if not isinstance(node, dict):
        raise SpecError(f"{where} is not a mapping or a list")
    then = parts[i + 1]
    if parts[i] not in node and then.isascii() and then.isdigit():
        given = clip(".".join(parts[:i + 1]), 80)
        raise SpecError(f"--set {key}: '{given}' is not in the scenario or its files (its "
                        f"default applies), so there is no item {clip(then, 12)} to set (give "
                        f"the whole list: --set {given}=[...])")
    return node.setdefault(parts[i], {})


def _item_index(items: list[Any], part: str, where: str) -> int:
    """`part` of a `--set` key as the index of an existing item of `items`."""
    span = f"index 0 to {len(items) - 1}" if items else "none"
    if not (part.isascii() and part.isdigit() and len(part) <= 9):
        raise SpecError(f"{where} is a list: '{clip(part, 40)}' is not an item index ({span})")
    if int(part) >= len(items):
        raise SpecError(f"{where} has {len(items)} item{'' if len(items) == 1 else 's'} "
                        f"({span}): there is no item {int(part)}")
    return int(part)


def _one_line(errors: list[dict[str, Any]], path: Path, overrides: list[str], marks: Marks,
              registries: core.Registries, prefix: tuple[str | int, ...] = ()) -> str:
    """The first validation error as `file:LINE:COLUMN: dotted.key: problem` for a value from
    a file (the key as written in that file: a world's, a model's), or `file: dotted.key
    (from --set): problem (got value)`; the value only when it came from `--set`."""
    first = errors[0]
    parts = [str(p) for p in (*prefix, *first.get("loc", ()))]
    # a discriminated union (a world's course shape) puts its tag into the location: not a key
    tags = union_tags(registries)
    keys = [p for p in parts if not p.startswith(("function-", "tagged")) and p not in tags]
    head, loc = _place(keys, path, overrides, marks)
    source = " (from --set)" if _set_by(loc, overrides) >= 0 else ""
    msg = clip(first["msg"].removeprefix("Value error, "))
    if first["type"] in BOUNDS:
        keys = [p for p in parts if not p.isdigit()]
        bound = next(iter((first.get("ctx") or {}).values()), "")
        msg = f"must be {BOUNDS[first['type']]} {bound:g} {unit_of(keys[-1] if keys else '')}"
        msg = msg.rstrip()
    elif first["type"] == "extra_forbidden":
        msg = "unknown key" + _did_you_mean_key(first)
    elif first["type"] == "missing" and msg == "Field required":
        msg = "required key is missing"
    got = first.get("input")
    # a value is echoed only when the user typed it: one from a file may be anything in it
    shown = "" if not source or first["type"] in ("missing", "extra_forbidden",
                                                  "unknown_plugin") or isinstance(
        got, dict) else f" (got {preview(got, 60)})"
    more = f" [+{len(errors) - 1} more]" if len(errors) > 1 else ""
    return f"{head}: {clip(loc) or '<top>'}{source}: {msg}{shown}{more}"


def _place(keys: list[str], path: Path, overrides: list[str], marks: Marks) -> tuple[str, str]:
    """Where an error at `keys` was written, `file:LINE:COLUMN`, and its key in that file:
    the mark of the longest recorded prefix of `keys`, unless a `--set` gave the value (a
    `--set` at least as deep as that prefix), when it is the scenario's `path` and its key."""
    loc = ".".join(keys)
    given = _set_by(loc, overrides)
    for n in range(len(keys), 0, -1):
        mark = marks.get(".".join(keys[:n]))
        if mark is not None and len(".".join(keys[:n])) > given:
            where, line, column, inner = mark
            return f"{where}:{line}:{column}", ".".join([inner, *keys[n:]])
    return str(path), loc


def _set_by(loc: str, overrides: list[str]) -> int:
    """The length of the longest `--set` key that gave the value at `loc` (that key or one
    holding it), -1 if none did."""
    return max((len(k) for o in overrides if loc == (k := o.split("=")[0].strip())
                or loc.startswith(f"{k}.")), default=-1)


def union_tags(registries: core.Registries) -> frozenset[str]:
    """The tags of the discriminated unions in every registered world kind's parameters (the
    line lab's `straight` and `circle` courses, a plugin world's own): what pydantic writes
    into an error's location between two keys. Read from the kinds' models, so a world added by
    a plugin needs no list here."""
    found: set[str] = set()
    for kind in registries.worlds.all():
        _tags_in(kind.params, found, set())
    return frozenset(found)


def _tags_in(annotation: Any, found: set[str], seen: set[Any]) -> None:
    """Collect discriminated-union tags from a type annotation (models, unions, containers)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        if annotation in seen:
            return
        seen.add(annotation)
        for field in annotation.model_fields.values():
            if isinstance(field.discriminator, str):
                for member in typing.get_args(_unannotated(field.annotation)):
                    tag = member.model_fields.get(field.discriminator) if (
                        isinstance(member, type) and issubclass(member, BaseModel)) else None
                    found.update(str(v) for v in typing.get_args(tag.annotation if tag else None))
            _tags_in(field.annotation, found, seen)
        return
    for arg in typing.get_args(annotation):
        _tags_in(arg, found, seen)


def _unannotated(annotation: Any) -> Any:
    """`Annotated[X, ...]` -> X."""
    return typing.get_args(annotation)[0] if typing.get_origin(annotation) is Annotated else (
        annotation)


BOUNDS = {"greater_than": "more than", "greater_than_equal": "at least",
          "less_than": "less than", "less_than_equal": "at most"}  # pydantic's error types


def _did_you_mean_key(error: dict[str, Any]) -> str:
    """For an unknown key, the nearest key the model has (from the error's context)."""
    ctx = error.get("ctx") or {}
    allowed = ctx.get("allowed")
    if not allowed:
        return ""
    return did_you_mean(str(error["loc"][-1]), allowed)


def load_scenario(name: str | Path, overrides: Sequence[str] | None = None, *, project: Project,
                  allow_outside_paths: bool = False,
                  registries: core.Registries = core.DEFAULT_REGISTRIES) -> Scenario:
    """Load and validate a scenario; every problem becomes one SpecError line.

    Args:
        name: A scenario name on the project's scenario path (`line_straight`), or the path of
            a YAML file (a `Path`, or a string ending in `.yaml` / `.yml` or holding a `/`).
        overrides: `dotted.key=value` assignments applied before validation, as `--set`.
        project: The project whose folders its names are looked up in (handed in by the entry
            point: the CLI, `kartci.api`, the pytest plugin); the scenario carries it.
        allow_outside_paths: Let track, world and model files (and the scenario's file when
            found by name) lie outside the project and kartci's data (`--allow-outside-paths`).
        registries: The controllers, robot kinds, world kinds, nodes and metric sets its names
            are looked up in (default: the process-wide ones, with every installed plugin).
    """
    return scenario_loader(name, project=project, allow_outside_paths=allow_outside_paths,
                           registries=registries)(overrides or ())


def scenario_loader(name: str | Path, *, project: Project, allow_outside_paths: bool = False,
                    registries: core.Registries = core.DEFAULT_REGISTRIES
                    ) -> Callable[[Sequence[str]], Scenario]:
    """`load_scenario(name, overrides)` for many override sets (a sweep's points): the file
    and the world and model files it names are read once, not once per point."""
    path = scenario_path(name, project)
    if path != Path(name):  # found by name in a scenario folder: maybe a symlink out of it
        project.contained(path, f"scenario {clip(str(name), 80)!r}", allow_outside_paths)
    marks: Marks = {}
    data = _read_yaml(path, marks)
    data.setdefault("name", path.stem)
    # what _validated does first: a no-op again
    _resolve_refs(data, path, project, allow_outside_paths, marks)

    def load(overrides: Sequence[str]) -> Scenario:
        return _validated(copy.deepcopy(data), path, list(overrides), project,
                          allow_outside_paths, dict(marks), registries)

    return load


def with_overrides(scenario: Scenario, overrides: Sequence[str], *, project: Project,
                   allow_outside_paths: bool = False,
                   registries: core.Registries = core.DEFAULT_REGISTRIES) -> Scenario:
    """A validated scenario with `dotted.key=value` overrides applied (validated again), in
    `project` (`in_project`); a relative log path in an override is relative to the working
    directory."""
    if not overrides:
        return in_project(scenario, project, allow_outside_paths)
    data = json.loads(scenario.model_dump_json())
    return _validated(data, Path(f"scenario {scenario.name}"), list(overrides), project,
                      allow_outside_paths, {}, registries)


def in_project(scenario: Scenario, proj: Project, allow_outside: bool = False) -> Scenario:
    """`scenario` carrying `proj` (`Scenario.project`: where its controllers find their data
    files), with each robot's URDF named relative to `<kind>/` (a kind's default, an inline
    model's) made its path on `proj`'s model path: resolved here, where the project is known,
    so no simulator or worker looks a path up again. A URDF not found stays as given (a robot
    that is never simulated needs none; one that is names it when it is built)."""
    agents = dict(scenario.agents)
    for name, agent in scenario.agents.items():
        urdf = agent.model.urdf
        if urdf and not Path(urdf).is_absolute():
            with contextlib.suppress(SpecError):
                found = proj.model_file(f"{agent.model.kind}/{urdf}", allow_outside)
                model = agent.model.model_copy(update={"urdf": str(found)})
                agents[name] = agent.model_copy(update={"model": model})
    out = scenario.model_copy(update={"agents": agents}) if agents != scenario.agents else (
        scenario.model_copy())
    out.attach(proj)
    return out


def _validated(data: dict[str, Any], path: Path, overrides: list[str], proj: Project,
               allow_outside: bool, marks: Marks, registries: core.Registries) -> Scenario:
    """`data` with the overrides applied, validated, in `proj`; `marks` (where each key was
    written) name the file and line of a bad value."""
    _resolve_refs(data, path, proj, allow_outside, marks)
    for assignment in overrides:
        apply_override(data, assignment)
        _forget(marks, assignment.partition("=")[0].strip())  # what it replaced
        # `--set world=line_lab/circle` names a file
        _resolve_refs(data, path, proj, allow_outside, marks)
    _resolve_command_line_paths(data, overrides, proj, allow_outside)
    try:
        with held(proj):  # a name the registries lack is looked up in `proj`'s plugins
            scenario = Scenario.model_validate(data, context=context(registries))
    except ParamsError as err:
        raise SpecError(_one_line(err.errors, path, overrides, marks, registries,
                                  err.loc)) from err
    except ValidationError as err:
        raise SpecError(_one_line(with_allowed_keys(Scenario, err), path, overrides,
                                  marks, registries)) from err
    except (ArithmeticError, RecursionError) as err:  # a validator's arithmetic on odd values
        raise SpecError(f"{path}: a value is out of range ({clip(str(err))})") from err
    return in_project(scenario, proj, allow_outside)


def scenario_from_json(text: str, registries: core.Registries = core.DEFAULT_REGISTRIES
                       ) -> Scenario:
    """Rebuild a resolved scenario from the JSON recorded in a run log."""
    try:
        return Scenario.model_validate_json(text, context=context(registries))
    except ValidationError as err:
        raise SpecError(f"recorded scenario: {err.errors()[0]['msg']}") from err


def json_schema() -> dict[str, Any]:
    """JSON Schema of a scenario file; `world` and `model` may also name a file by string."""
    return scenario_schema()
