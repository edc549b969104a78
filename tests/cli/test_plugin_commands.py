"""Commands a kind or plugin adds through the `kartci.commands` entry points: found from the
installed metadata, and a plugin that fails to import takes only its own command down."""

from __future__ import annotations

from importlib.metadata import EntryPoint, entry_points

import pytest
from typer.testing import CliRunner

from kartci.cli import app, common, main


def test_the_line_trackers_commands_come_from_its_entry_point() -> None:
    names = {ep.name for ep in entry_points(group=common.COMMANDS_GROUP)}
    assert "line_tracker" in names
    assert {"characterise", "study"} <= set(common.plugin_commands())


def test_a_plugin_that_fails_to_import_breaks_only_its_own_command(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    broken = EntryPoint("team_tools", "no_such_module_kartci_test:app", common.COMMANDS_GROUP)
    monkeypatch.setattr(common, "entry_points", lambda group: [broken])
    common.plugin_commands.cache_clear()
    try:
        listing = CliRunner().invoke(app, ["--help"])
        assert listing.exit_code == 0
        assert "team_tools" in listing.output and "run" in listing.output
        monkeypatch.setattr("sys.argv", ["kartci", "team_tools"])
        with pytest.raises(SystemExit) as stop:
            main()
        assert stop.value.code == 2
        assert capsys.readouterr().err == (
            "kartci: error: the commands of plugin 'team_tools' (kartci.commands) failed to "
            "import: ModuleNotFoundError: No module named 'no_such_module_kartci_test'\n")
    finally:
        common.plugin_commands.cache_clear()
