"""The scenario JSON Schema: built from the registries, every key described, and it accepts
every shipped scenario (as written and fully resolved) while rejecting what loading rejects."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import pytest
import yaml
from pydantic import Field

from kartci import core
from kartci.core import Agent
from kartci.project import BUILTIN_SCENARIOS
from kartci.project import current as active_project
from kartci.scenario import json_schema, load_scenario
from kartci.scenario.models import ControllerParams
from kartci.scenario.schema import scenario_schema

jsonschema = pytest.importorskip("jsonschema", reason="pip install jsonschema (the dev extra)")

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "pure_pursuit"
SHIPPED = sorted(BUILTIN_SCENARIOS.glob("*.yaml"))
MODELINE = "# yaml-language-server: $schema="


def validator(schema: dict[str, Any]) -> Any:
    cls = jsonschema.Draft202012Validator
    cls.check_schema(schema)
    return cls(schema)


@pytest.fixture(scope="module")
def schema() -> dict[str, Any]:
    return scenario_schema()


@pytest.fixture
def pure_pursuit() -> Iterator[None]:
    """The example team package's plugins, registered for one test as its entry points would
    register them when installed."""
    sys.path.insert(0, str(EXAMPLE / "src"))
    try:
        mod = importlib.import_module("kartci_pure_pursuit")
        added = [(reg, item) for reg, item in ((core.CONTROLLERS, mod.CONTROLLER),
                                               (core.METRICS, mod.CORNERING))
                 if item.name not in reg.names()]
        for reg, item in added:
            reg.register(item)
        try:
            yield
        finally:
            for reg, item in added:
                del reg.items[item.name]
    finally:
        sys.path.remove(str(EXAMPLE / "src"))


def test_schema_is_draft_2020_12_with_an_id(schema: dict[str, Any]) -> None:
    import kartci

    validator(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["$id"] == f"https://kartci.invalid/schema/scenario-{kartci.__version__}.json"
    assert json_schema() == schema  # the old entry point gives the same schema
    assert "name" not in schema["required"]  # the file name is the default


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_scenario_validates_as_written_and_resolved(
        path: Path, schema: dict[str, Any]) -> None:
    check = validator(schema)
    check.validate(yaml.safe_load(path.read_text(encoding="utf-8")))
    # what `kartci show` prints
    resolved = load_scenario(str(path), project=active_project()).model_dump(mode="json")
    check.validate(resolved)


def test_the_example_team_scenario_validates(pure_pursuit: None) -> None:
    check = validator(scenario_schema())
    for path in sorted((EXAMPLE / "scenarios").glob("*.yaml")):
        check.validate(yaml.safe_load(path.read_text(encoding="utf-8")))


@pytest.mark.parametrize("path", [*SHIPPED, *sorted((EXAMPLE / "scenarios").glob("*.yaml"))],
                         ids=lambda p: p.stem)
def test_scenarios_name_the_generated_schema_in_their_first_line(path: Path) -> None:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith(MODELINE), first
    target = first.removeprefix(MODELINE)
    assert target.endswith(".kartci/scenario.schema.json"), target
    # relative to the scenario file, it lands in the project root's .kartci/ folder
    project_root = ROOT if path.is_relative_to(BUILTIN_SCENARIOS) else EXAMPLE
    assert (path.parent / target).resolve() == project_root / ".kartci" / "scenario.schema.json"


def _properties(node: Any, where: str = "#") -> Iterator[tuple[str, Any]]:
    """Every (location, schema) under a `properties` or `patternProperties` anywhere."""
    if isinstance(node, dict):
        for key in ("properties", "patternProperties"):
            for name, sub in (node.get(key) or {}).items():
                yield f"{where}/{key}/{name}", sub
        for key, sub in node.items():
            yield from _properties(sub, f"{where}/{key}")
    elif isinstance(node, list):
        for i, sub in enumerate(node):
            yield from _properties(sub, f"{where}/{i}")


def test_every_property_at_every_level_has_a_description(schema: dict[str, Any]) -> None:
    found = list(_properties(schema))
    assert len(found) > 150
    missing = [where for where, sub in found if not str(sub.get("description", "")).strip()]
    assert not missing, missing
    # ... and every alternative of a plugin-typed key says what it is
    agent = schema["$defs"]["AgentSpec"]["properties"]
    metric_sets = schema["properties"]["metrics"]["properties"]
    for part in (schema["properties"]["world"], agent["model"], agent["controller"],
                 agent["sensors"], *metric_sets.values()):
        for alt in _alternatives(part):
            assert alt.get("description"), alt


def _alternatives(node: dict[str, Any]) -> Iterator[dict[str, Any]]:
    for key in ("anyOf", "oneOf"):
        for alt in node.get(key, []):
            yield alt
            yield from _alternatives(alt)


def test_every_registered_plugin_appears(schema: dict[str, Any]) -> None:
    text = json.dumps(schema)
    defs = schema["$defs"]
    for reg in core.REGISTRIES:
        for item in reg.all():
            for model in (item.params, getattr(item, "sensors", None)):
                if model is not None:
                    assert model.__name__ in defs, (reg.what, item.name)
            assert f"`{item.name}`" in text, (reg.what, item.name)
    assert set(schema["properties"]["metrics"]["properties"]) == set(core.METRICS.names())
    from kartci.metrics import definitions

    criteria = schema["properties"]["criteria"]["properties"]
    assert set(criteria) == set(definitions())
    assert "[m]" in criteria["cross_track_rms_m"]["description"]


class HoldSpeed(ControllerParams):
    """A test controller's own parameters."""

    type: Literal["schema_test_hold"] = Field("schema_test_hold", description="controller type")
    speed_mps: float = Field(1.5, gt=0.0, description="speed to hold, m/s")


class LooseParams(ControllerParams):
    """A plugin model that leaves `type` a plain string (no Literal)."""

    gain: float = Field(1.0, description="a gain, 1")


def _not_run(params: ControllerParams, ctx: core.AgentContext) -> Agent:
    raise AssertionError("the schema never builds a controller")


def test_a_plugin_registered_at_run_time_appears() -> None:
    ctl = core.Controller("schema_test_hold", HoldSpeed, _not_run, ("gokart",),
                             "holds a speed")
    core.register(ctl)
    try:
        schema = scenario_schema()
        assert schema["$defs"]["HoldSpeed"]["properties"]["speed_mps"]["description"]
        check = validator(schema)
        doc = {"description": "x", "world": "winti/hall", "duration_s": 1.0,
               "agents": {"kart0": {"model": "gokart",
                                    "controller": {"type": "schema_test_hold", "speed_mps": 2}}}}
        check.validate(doc)
        doc["agents"]["kart0"]["controller"]["speed_mps"] = -1  # type: ignore[index]
        assert not check.is_valid(doc)
    finally:
        del core.CONTROLLERS.items["schema_test_hold"]
    assert "HoldSpeed" not in scenario_schema()["$defs"]


def test_a_plugin_with_an_untyped_name_does_not_swallow_the_others() -> None:
    core.register(core.Controller("schema_test_loose", LooseParams, _not_run))
    try:
        check = validator(scenario_schema())
        doc = yaml.safe_load((BUILTIN_SCENARIOS / "mpcc_lap.yaml").read_text("utf-8"))
        check.validate(doc)  # `type: mpcc` matches the MPCC alone, not LooseParams too
        doc["agents"]["kart0"]["controller"] = {"type": "schema_test_loose", "gain": 2.0}
        check.validate(doc)
    finally:
        del core.CONTROLLERS.items["schema_test_loose"]


@pytest.mark.parametrize(("path", "value"), [
    ("agents.lt0.controller.type", "line_pd"),  # unknown controller
    ("agents.lt0.controller.kpp", 3),  # misspelt key
    ("agents.lt0.sensors.line_sensor.mode", "ray"),  # not a choice
    ("metrics.line_trackin", {}),  # unknown metric set
    ("criteria.cross_track_rms", {"max": 1}),  # unknown metric
    ("world", {"from": "line_lab/straight", "line_width": 0.02}),  # misspelt world key
    ("duration_s", 0),  # out of range
])
def test_what_loading_rejects_the_schema_rejects(path: str, value: Any,
                                                 schema: dict[str, Any]) -> None:
    doc = yaml.safe_load((BUILTIN_SCENARIOS / "line_straight.yaml").read_text("utf-8"))
    check = validator(schema)
    check.validate(doc)
    node = doc
    *parents, last = path.split(".")
    for key in parents:
        node = node[key]
    node[last] = value
    assert not check.is_valid(doc), path


def _schema_cli(out: Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kartci.cli", "schema", "--out", str(out)],
                          capture_output=True, text=True, cwd=cwd, timeout=120)


@pytest.mark.long(reason="kartci runs end to end")
def test_cli_writes_the_schema_into_a_new_folder(tmp_path: Path) -> None:
    out = tmp_path / ".kartci" / "scenario.schema.json"
    p = _schema_cli(out, tmp_path)
    assert p.returncode == 0, p.stderr
    assert json.loads(out.read_text(encoding="utf-8")) == scenario_schema()
    blocked = tmp_path / "a_file"
    blocked.write_text("x")
    p = _schema_cli(blocked / "sub" / "scenario.schema.json", tmp_path)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert "scenario.schema.json: cannot be written (Not a directory)" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1
