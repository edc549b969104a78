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
from kartci.core.loading import load_entry_point
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
    load_entry_point(reg, EntryPoint("stanley", "no_such_module_kartci_test:STANLEY",
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


def test_a_plugin_that_calls_sys_exit_while_loading_is_recorded_as_broken_by_name(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`sys.exit(0)` at import is the plugin's failure, not kartci's end (which was a green
    exit with nothing run): recorded under the entry point's name as `SystemExit: 0`."""
    (tmp_path / "kartci_test_quitter.py").write_text("import sys\nsys.exit(0)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    reg: Registry[Controller] = Registry("kartci.controllers", "controller", Controller)
    load_entry_point(reg, EntryPoint("quitter", "kartci_test_quitter:QUITTER",
                                      "kartci.controllers"))
    assert reg.broken["quitter"].error == "SystemExit: 0"
    with pytest.raises(PluginError, match=r"plugin 'quitter' .* failed to load: SystemExit: 0"):
        reg.get("quitter")


def test_a_keyboard_interrupt_while_a_plugin_loads_still_stops_kartci(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C during an import cannot be told from a plugin raising KeyboardInterrupt, and a
    real Ctrl-C must stop kartci: it propagates (the command then exits 130)."""
    (tmp_path / "kartci_test_interrupted.py").write_text("raise KeyboardInterrupt\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    reg: Registry[Controller] = Registry("kartci.controllers", "controller", Controller)
    with pytest.raises(KeyboardInterrupt):
        load_entry_point(reg, EntryPoint("interrupted", "kartci_test_interrupted:X",
                                          "kartci.controllers"))


def project_with_plugin(root: Path, source: str) -> Path:
    """A project whose one plugin module is `source`."""
    (root / "scenarios").mkdir(parents=True)
    (root / "kartci.toml").write_text('plugins = ["team_plugin"]\n')
    (root / "team_plugin.py").write_text(source)
    return root


def test_a_ci_run_with_a_plugin_module_that_exits_0_fails_with_exit_2_and_writes_nothing(
        tmp_path: Path) -> None:
    proj = project_with_plugin(tmp_path / "proj", "import sys\nsys.exit(0)\n")
    out = tmp_path / "out"
    p = kartci("run", "line_straight", "--out", out, cwd=proj, env={"CI": "true"})
    assert p.returncode == 2, p.stderr
    assert p.stderr.startswith(
        "kartci: error: plugin 'team_plugin' (plugin module of kartci.toml) failed to load: "
        "SystemExit: 0 (strict mode, as under CI: a plugin that fails to load fails the run;")
    assert len(p.stderr.splitlines()) == 1
    assert not out.exists()


def test_a_strict_run_with_a_broken_installed_plugin_is_exit_2_even_if_no_scenario_names_it(
        tmp_path: Path) -> None:
    site = tmp_path / "site"
    installed_broken_plugin(site)
    path = os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])
    p = kartci("run", "line_straight", "--strict", "--out", tmp_path / "out", cwd=tmp_path,
               env={"PYTHONPATH": path})
    assert p.returncode == 2, p.stderr
    assert ("plugin 'stanley' (entry point team_broken:STANLEY of team-broken 0.1, group "
            "kartci.controllers) failed to load: RuntimeError: stanley gains not tuned") in p.stderr
    assert not (tmp_path / "out").exists()


def test_plugins_and_list_exit_1_when_a_plugin_is_broken_and_still_list_everything(
        tmp_path: Path) -> None:
    """As `pip check` does: the listing is shown, the broken plugin named on stderr, exit 1."""
    site = tmp_path / "site"
    installed_broken_plugin(site)
    env = {"PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])}
    for command in ("plugins", "list"):
        p = kartci(command, cwd=tmp_path, env=env)
        assert p.returncode == 1, (command, p.stderr)
        assert "line_pid" in p.stdout if command == "plugins" else "line_straight" in p.stdout
        assert p.stderr == (
            "kartci: error: plugin 'stanley' (entry point team_broken:STANLEY of team-broken "
            "0.1, group kartci.controllers) failed to load: RuntimeError: stanley gains not "
            "tuned\n")
    assert kartci("plugins", cwd=tmp_path).returncode == 0


def test_what_a_plugin_prints_while_it_loads_goes_to_stderr_and_schema_stays_json(
        tmp_path: Path) -> None:
    """Both Python's print and a write to file descriptor 1 (a C extension, a child process)."""
    proj = project_with_plugin(tmp_path / "proj", (
        "import os\nprint('loading team plugin')\nos.write(1, b'raw fd write\\n')\n"))
    p = kartci("schema", cwd=proj)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["title"]
    assert "loading team plugin" in p.stderr and "raw fd write" in p.stderr
    p = kartci("show", "line_straight", cwd=proj)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["name"] == "line_straight"
    assert "loading team plugin" in p.stderr
