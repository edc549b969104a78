"""The pytest plugin, run by pytest's own `pytester` in a temporary kartci project: scenario
files as test items (selection, markers, the verdict table as failure text), the `kartci_run`
fixture, and pytest-xdist."""

from __future__ import annotations

import importlib
import json
import tomllib
from pathlib import Path

import pytest
import yaml

from kartci.project import BUILTIN_SCENARIOS

pytest_plugins = ["pytester"]

ROOT = Path(__file__).resolve().parents[2]
# The inner runs load only kartci's plugin (and xdist where asked), whatever else the venv has
# installed; in-process runs find it imported already, so it cannot be assertion-rewritten.
PLUGIN = ("-p", "kartci.pytest_plugin", "-W", "ignore::pytest.PytestAssertRewriteWarning")


def _scenario(**changes: object) -> str:
    """The built-in straight-line scenario, short: 3 s, a 1 s transient, one criterion."""
    data = yaml.safe_load((BUILTIN_SCENARIOS / "line_straight.yaml").read_text())
    data.update(duration_s=3.0, metrics={"line_tracking": {"transient_s": 1.0}},
                criteria={"line_lost": {"equal": 0}}, tags=["line", "quick-check"])
    data.update(changes)
    return yaml.safe_dump(data, sort_keys=False)


@pytest.fixture(scope="module")
def warm(tmp_path_factory: pytest.TempPathFactory) -> None:
    """One short run here first: pytester's in-process runs drop the modules they import, and
    numpy cannot be imported twice in one process; modules imported before they start stay."""
    import kartci

    kartci.run("line_straight", overrides=["duration_s=0.1", "metrics.line_tracking."
                                           "transient_s=0"], out=tmp_path_factory.mktemp("warm"))


@pytest.fixture
def project(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch,
            warm: None) -> pytest.Pytester:
    """A team's repository: [tool.kartci], a scenario folder, other YAML around."""
    monkeypatch.delenv("KARTCI_ROOT", raising=False)
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.makepyprojecttoml('[tool.kartci]\nscenarios = ["scenarios"]\n'
                               'baselines = "baselines"\n')
    (pytester.path / "scenarios").mkdir()
    (pytester.path / "baselines").mkdir()
    (pytester.path / "scenarios" / "line_straight.yaml").write_text(_scenario())
    (pytester.path / "scenarios" / "notes.yaml").write_text("owner: someone\nworld_cup: no\n")
    (pytester.path / "deploy").mkdir()  # a scenario-looking file outside the scenario folders
    (pytester.path / "deploy" / "stray.yaml").write_text(_scenario())
    (pytester.path / "config.yaml").write_text("world: 1\nagents: 2\n")
    return pytester


def test_the_entry_point_names_the_plugin_module() -> None:
    eps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert eps["pytest11"] == {"kartci": "kartci.pytest_plugin"}
    assert hasattr(importlib.import_module("kartci.pytest_plugin"), "kartci_run")


def test_scenario_files_are_collected_only_where_asked(project: pytest.Pytester) -> None:
    strict = (*PLUGIN, "--collect-only", "-q", "--strict-markers",
              "-W", "error::pytest.PytestUnknownMarkWarning")
    result = project.runpytest(*strict, "scenarios/")
    result.stdout.fnmatch_lines(["scenarios/line_straight.yaml::line_straight", "*1 test*"])
    assert "notes" not in result.stdout.str()
    # no path given: the project's scenario folders only, never other YAML in the repository
    result = project.runpytest(*strict)
    assert "scenarios/line_straight.yaml::line_straight" in result.stdout.str()
    assert "stray.yaml" not in result.stdout.str() and "config.yaml" not in result.stdout.str()
    # a path given is collected even outside the scenario folders
    result = project.runpytest(*strict, "deploy/stray.yaml")
    result.stdout.fnmatch_lines(["deploy/stray.yaml::stray"])
    # -k and markers from the scenario's tags (a tag that is no identifier is made one)
    for selection, count in ((("-k", "straight"), 1), (("-k", "circle"), 0),
                             (("-m", "quick_check and line"), 1), (("-m", "kartci"), 1),
                             (("-m", "not line"), 0)):
        result = project.runpytest(*strict, "scenarios/", *selection)
        got = result.stdout.str().count("scenarios/line_straight.yaml::line_straight")
        assert got == count, (selection, result.stdout.str())


def test_a_scenario_item_passes_then_fails_with_the_verdict_table(
        project: pytest.Pytester) -> None:
    result = project.runpytest(*PLUGIN, "scenarios/")
    result.assert_outcomes(passed=1)  # no baseline yet: every metric new, not a failure
    (project.path / "baselines" / "line_straight.json").write_text(json.dumps({"metrics": {
        "mean_speed_mps": {"value": 0.5, "unit": "m/s", "tolerance": 0.01,
                           "direction": "higher"}}}))
    result = project.runpytest(*PLUGIN, "scenarios/")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines([
        "*scenario line_straight: regressed*",
        "metric*value*baseline*delta*tolerance*verdict*",
        "mean_speed_mps*0.09633 m/s*0.5 m/s*-0.404*±0.01 (higher)*regressed*",
        "criterion line_lost*0*== 0*pass*",
        "log: *line_straight/run.mcap",
    ])
    assert "Traceback" not in result.stdout.str()


def test_a_run_shorter_than_its_transient_fails_with_both_times(
        project: pytest.Pytester) -> None:
    (project.path / "scenarios" / "line_straight.yaml").write_text(
        _scenario(metrics={"line_tracking": {"transient_s": 8.0}}))
    result = project.runpytest(*PLUGIN, "scenarios/")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*SpecError: scenario line_straight, agent lt0: "
                                 "metrics.line_tracking.transient_s is 8 s but the run lasts "
                                 "3 s (duration_s 3 s)*"])


def test_kartci_accept_stores_each_scenario_items_baseline(project: pytest.Pytester) -> None:
    """`--kartci-accept` calls what `kartci baseline update` calls: conditioning replicas,
    scenario hash, what changed listed once at the end; the next session is judged against it."""
    result = project.runpytest(*PLUGIN, "--kartci-accept", "scenarios/")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["*kartci baselines accepted*",
                                 "line_straight: * of * metrics changed",
                                 "  added    completion: — -> *",
                                 "  worst-conditioned: *"])
    stored = json.loads((project.path / "baselines" / "line_straight.json").read_text())
    assert stored["conditioning"]["replicas"] == 4 and stored["scenario_hash"]
    result = project.runpytest(*PLUGIN, "scenarios/", "-rP")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["scenario line_straight: pass", "*completion*1*pass*"])
    assert "kartci baselines accepted" not in result.stdout.str()
    # the file edited since: judged as `kartci run` judges it, the baseline called stale
    (project.path / "scenarios" / "line_straight.yaml").write_text(_scenario(duration_s=3.5))
    result = project.runpytest(*PLUGIN, "scenarios/", "-rA")
    result.stdout.fnmatch_lines(["warning: baseline is stale: scenario changed since it was "
                                 "accepted (fields: duration_s)*"])


TEST_MINE = '''
from typing import Any

import numpy as np

from kartci.logs import header, msg


class Straight:
    period_s = 0.06
    inputs = ()

    def on_message(self, topic: str, message: Any) -> None:
        pass

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        return [("wheel_cmd", msg("sensor_msgs/msg/JointState", header=header(t_ns, "base_link"),
                                  name=[], position=np.zeros(0), effort=np.zeros(0),
                                  velocity=np.array([2.0, 2.0])))]


def test_my_controller_keeps_the_line(kartci_run):
    result = kartci_run("line_straight", "duration_s=2", "metrics.line_tracking.transient_s=1")
    assert result.value("line_lost") == 0 and result.log.is_file()
    assert result.value("mean_speed_mps") > 0.05


def test_open_loop_drives_straight(kartci_run):
    result = kartci_run("line_straight", "duration_s=2", "metrics.line_tracking.transient_s=1",
                        agents={"lt0": Straight()})
    assert result.replaced_agents == {"lt0": "test_mine.Straight"}
    assert abs(result.value("mean_speed_mps") - 2.0 * 0.035) < 0.01
'''


def test_the_kartci_run_fixture_returns_results_for_my_asserts(
        project: pytest.Pytester) -> None:
    project.makepyfile(test_mine=TEST_MINE)
    result = project.runpytest(*PLUGIN, "test_mine.py")
    result.assert_outcomes(passed=2)


def test_kartci_shard_deals_the_scenario_items_into_shares_that_merge(
        project: pytest.Pytester) -> None:
    """`--kartci-shard I/N` deals the items as `kartci run --shard` deals scenarios, and with
    `--kartci-out` each share's DIR is a partial result `kartci.merge` joins."""
    import kartci

    (project.path / "scenarios" / "line_circle.yaml").write_text(
        _scenario(world="line_lab/circle", description="a circle, short", criteria={}))
    for i in (1, 2):
        result = project.runpytest(*PLUGIN, "scenarios/", "--kartci-shard", f"{i}/2",
                                   "--kartci-out", f"s{i}")
        result.assert_outcomes(passed=1, deselected=1)
    assert json.loads((project.path / "s1" / "shard.json").read_text()) == {
        "index": 1, "total": 2, "scenarios": ["line_circle"]}
    merged = kartci.merge([project.path / "s1", project.path / "s2"],
                          out=project.path / "merged", baselines=project.path / "baselines")
    assert [r.name for r in merged.results] == ["line_circle", "line_straight"]
    assert merged.passed
    result = project.runpytest(*PLUGIN, "scenarios/", "--kartci-shard", "3/2")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    assert "--kartci-shard '3/2': expected I/N with 1 <= I <= N" in result.stderr.str()


@pytest.mark.long(reason="pytest under xdist in a subprocess")
def test_scenario_items_and_the_fixture_run_under_xdist(project: pytest.Pytester) -> None:
    pytest.importorskip("xdist")
    (project.path / "scenarios" / "line_circle.yaml").write_text(
        _scenario(world="line_lab/circle", description="a circle, short", criteria={}))
    project.makepyfile(test_mine=TEST_MINE)
    result = project.runpytest_subprocess(*PLUGIN, "-p", "xdist.plugin", "-n", "2",
                                          "scenarios/", "test_mine.py")
    result.assert_outcomes(passed=4)
    result.stdout.fnmatch_lines(["*2 workers*"])
