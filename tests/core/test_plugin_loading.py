"""Plugins load one by one: a broken installed plugin (entry point) or project plugin module is
reported once, by name, with its own error, and only the scenarios that name it fail."""

from __future__ import annotations

import json
import os
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest
import yaml
from helpers import QUICK, kartci

from kartci.core import Controller, Registry
from kartci.core.registry import _load_entry_point
from kartci.errors import PluginError
from kartci.project import BUILTIN_SCENARIOS

BROKEN_DIST = """\
[kartci.controllers]
stanley = team_broken:STANLEY
"""


def installed_broken_plugin(site: Path) -> None:
    """A distribution installed the way pip leaves one (a dist-info with entry points) whose
    module raises on import."""
    info = site / "team_broken-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: team-broken\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(BROKEN_DIST)
    (site / "team_broken.py").write_text('raise RuntimeError("stanley gains not tuned")\n')


def scenario_with_controller(path: Path, controller: str) -> None:
    spec = yaml.safe_load((BUILTIN_SCENARIOS / "line_straight.yaml").read_text())
    spec["agents"]["lt0"]["controller"] = {"type": controller}
    path.write_text(yaml.safe_dump(spec))


def test_a_broken_entry_point_is_recorded_under_its_name_not_raised() -> None:
    reg: Registry[Controller] = Registry("kartci.controllers", "controller", Controller)
    _load_entry_point(reg, EntryPoint("stanley", "no_such_module_kartci_test:STANLEY",
                                      "kartci.controllers"))
    assert reg.items == {}
    with pytest.raises(PluginError) as err:
        reg.get("stanley")
    assert str(err.value) == (
        "plugin 'stanley' (entry point no_such_module_kartci_test:STANLEY, group "
        "kartci.controllers) failed to load: ModuleNotFoundError: No module named "
        "'no_such_module_kartci_test'")
    assert "Traceback (most recent call last)" in err.value.trace


@pytest.mark.long(reason="kartci runs end to end")
def test_broken_plugins_fail_only_the_scenarios_that_name_them(tmp_path: Path,
                                                               baselines: Path) -> None:
    """An installed plugin that raises on import and a project plugin module that raises
    ValueError: the built-in scenario runs and is judged; each scenario naming a broken plugin
    is an error naming it, with the plugin's traceback in its folder; exit 2."""
    site = tmp_path / "site"
    installed_broken_plugin(site)
    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('plugins = ["team_plugin"]\n')
    (proj / "team_plugin.py").write_text('raise ValueError("missing gain table")\n')
    scenario_with_controller(proj / "scenarios" / "needs_stanley.yaml", "stanley")
    scenario_with_controller(proj / "scenarios" / "needs_team.yaml", "team_pid")
    out = tmp_path / "out"
    path = os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])
    p = kartci("run", "line_straight", "needs_stanley", "needs_team", *QUICK, "--out", out,
               "--baselines", baselines, cwd=proj, env={"PYTHONPATH": path})
    assert p.returncode == 2, p.stderr
    assert "internal error" not in p.stderr and "Traceback" not in p.stdout + p.stderr
    warnings = [line for line in p.stderr.splitlines() if line.startswith("kartci: warning")]
    assert len(warnings) == 2
    assert warnings[0].startswith(
        "kartci: warning: plugin 'stanley' (entry point team_broken:STANLEY of team-broken "
        "0.1, group kartci.controllers) failed to load: RuntimeError: stanley gains not tuned")
    assert warnings[1].startswith("kartci: warning: plugin 'team_plugin' (plugin module of "
                                  "kartci.toml) failed to load: ValueError: missing gain table")
    summary = json.loads((out / "summary.json").read_text())["scenarios"]
    assert summary["line_straight"]["status"] == "new"
    assert summary["needs_stanley"]["status"] == "error"
    assert summary["needs_stanley"]["error"].endswith(
        "needs_stanley.yaml:4:7: agents.lt0.controller.type: plugin 'stanley' (entry point "
        "team_broken:STANLEY of team-broken 0.1, group kartci.controllers) failed to load: "
        "RuntimeError: stanley gains not tuned")
    assert summary["needs_team"]["status"] == "error"
    assert summary["needs_team"]["error"].endswith(
        "needs_team.yaml:4:7: agents.lt0.controller.type: unknown controller 'team_pid'; plugin "
        "'team_plugin' (plugin module of kartci.toml) failed to load: ValueError: missing gain "
        "table")
    trace = (out / "needs_stanley" / "traceback.txt").read_text()
    assert 'team_broken.py", line 1' in trace and trace.endswith(
        "RuntimeError: stanley gains not tuned\n")
    assert 'team_plugin.py", line 1' in (out / "needs_team" / "traceback.txt").read_text()
