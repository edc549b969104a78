"""The command line as a user meets it: exit codes, one-line errors, files written."""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from helpers import ROOT, kartci

from kartci.project import BUILTIN_SCENARIOS

SCENARIOS = BUILTIN_SCENARIOS

SHORT = ["--set", "duration_s=4", "--set", "criteria={}",
         "--set", "metrics.line_tracking.transient_s=1"]




def _one_clean_line(p: subprocess.CompletedProcess[str]) -> str:
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr + p.stdout
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    return lines[0]


def _commands() -> list[list[str]]:
    """Every command and command group of the CLI, found from the app itself (typer's own
    click: groups are told by their `commands`), the robot kinds' own commands included (the
    top-level group lists them: `list_commands`, `get_command`)."""
    import typer

    from kartci.cli import app

    found: list[list[str]] = [[]]

    def walk(group: Any, prefix: list[str]) -> None:
        for name in sorted(group.list_commands(None)):
            cmd = group.get_command(None, name)
            found.append([*prefix, name])
            if hasattr(cmd, "commands"):
                walk(cmd, [*prefix, name])

    walk(typer.main.get_command(app), [])
    return found


COMMANDS = _commands()


def test_every_command_is_found() -> None:
    names = {" ".join(c) for c in COMMANDS}
    assert {"init", "list", "show", "run", "report", "schema", "characterise", "baseline",
            "baseline update", "merge", "compare", "plugins", "replay", "extract", "diff"} <= names


@pytest.mark.parametrize("cmd", COMMANDS, ids=lambda c: " ".join(c) or "kartci")
def test_help_on_every_command(cmd: list[str]) -> None:
    from typer.testing import CliRunner

    from kartci.cli import app

    result = CliRunner().invoke(app, [*cmd, "--help"], prog_name="kartci")
    assert result.exit_code == 0, (cmd, result.output)
    assert f"Usage: kartci {' '.join(cmd)}".strip() in result.output


def test_help_is_shown_as_written_and_version() -> None:
    p = kartci("run", "--help")
    assert p.returncode == 0, p.stderr
    text = " ".join(p.stdout.split())
    assert 'pip install "kartci[ray]"' in text  # rich markup would eat [ray]...
    assert "[default: the project's reports/<command>]" in text  # ...and [default: ...]
    assert p.stdout.startswith("Usage: kartci run")
    from kartci import __version__

    v = kartci("--version")
    assert v.returncode == 0 and v.stdout == f"kartci {__version__}\n"


def test_shell_completion_of_scenario_names(tmp_path: Path) -> None:
    (tmp_path / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "line_team.yaml").write_text("description: ours\n")
    for cmd in ("run", "show"):
        p = kartci(cwd=tmp_path, env={"_KARTCI_COMPLETE": "complete_bash",
                                      "COMP_WORDS": f"kartci {cmd} line_", "COMP_CWORD": "2"})
        assert p.returncode == 0, p.stderr
        words = p.stdout.split()
        builtin = sorted(f.stem for f in (ROOT / "scenarios").glob("line_*.yaml"))
        assert words == sorted([*builtin, "line_team"]) and "line_circle" in words
    p = kartci(cwd=tmp_path, env={"_KARTCI_COMPLETE": "complete_zsh",
                                  "_TYPER_COMPLETE_ARGS": "kartci run line_t"})
    assert '"line_team":"project"' in p.stdout
    shown = kartci("--show-completion", "bash")
    assert shown.returncode == 0 and "_KARTCI_COMPLETE" in shown.stdout


def test_missing_scenario(tmp_path: Path) -> None:
    line = _one_clean_line(kartci("run", "no_such_scenario", "--out", tmp_path))
    assert "unknown scenario 'no_such_scenario'" in line


def test_unknown_set_key(tmp_path: Path) -> None:
    line = _one_clean_line(kartci("run", "line_straight", "--set", "agents.lt0.foo=1",
                                  "--out", tmp_path))
    assert "agents.lt0.foo" in line and "unknown key" in line


def test_malformed_scenario_file(tmp_path: Path) -> None:
    bad = tmp_path / "broken.yaml"
    bad.write_text("description: [oops\n")
    line = _one_clean_line(kartci("run", bad, "--out", tmp_path / "out"))
    assert "broken.yaml" in line


def test_run_twice_gives_byte_identical_metrics(tmp_path: Path) -> None:
    """Same scenario and seed, two processes: identical metrics.json, byte for byte."""
    base = tmp_path / "b"
    base.mkdir()
    for out in ("a", "b2"):
        p = kartci("run", "line_straight", *SHORT, "--out", tmp_path / out, "--baselines", base)
        assert p.returncode == 0, p.stderr
    a = (tmp_path / "a" / "line_straight" / "metrics.json").read_bytes()
    b = (tmp_path / "b2" / "line_straight" / "metrics.json").read_bytes()
    assert a == b
    other = kartci("run", "line_straight", *SHORT, "--set", "seed=2", "--out", tmp_path / "c",
                   "--baselines", base)
    assert other.returncode == 0
    c = (tmp_path / "c" / "line_straight" / "metrics.json").read_bytes()
    assert c != a  # the seed drives the sensor noise


def test_baseline_cycle_and_a_tightened_baseline_fails(tmp_path: Path) -> None:
    out, base = tmp_path / "out", tmp_path / "baselines"
    base.mkdir()
    assert kartci("run", "line_straight", *SHORT, "--out", out, "--baselines", base
                  ).returncode == 0
    assert not any(base.iterdir())  # a run never writes baselines
    upd = kartci("baseline", "update", out, "--baselines", base)
    assert upd.returncode == 0, upd.stderr
    assert "added" in upd.stdout
    stored = json.loads((base / "line_straight.json").read_text())
    assert stored["metrics"]["cross_track_rms_m"]["direction"] == "lower"

    again = kartci("run", "line_straight", *SHORT, "--out", out, "--baselines", base)
    assert again.returncode == 0, again.stdout
    # tighten: pretend the baseline was 10x better with a tiny tolerance
    entry = stored["metrics"]["cross_track_rms_m"]
    entry["value"], entry["tolerance"] = entry["value"] / 10, 1e-9
    (base / "line_straight.json").write_text(json.dumps(stored))
    before = (base / "line_straight.json").read_text()
    worse = kartci("run", "line_straight", *SHORT, "--out", out, "--baselines", base)
    assert worse.returncode == 1
    assert "cross_track_rms_m" in worse.stdout and "REGRESSED" in worse.stdout
    assert (base / "line_straight.json").read_text() == before  # untouched by the run
    html = (out / "report.html").read_text()
    assert "cross_track_rms_m" in html and 'class="regressed"' in html and 'class="kfigs"' in html
    md = (out / "summary.md").read_text()
    assert "`cross_track_rms_m`" in md and "regressed" in md
    summary = json.loads((out / "summary.json").read_text())
    assert summary["exit_code"] == 1
    assert summary["scenarios"]["line_straight"]["metrics"]["cross_track_rms_m"]["status"] == (
        "regressed")
    suite = ET.parse(out / "junit.xml").getroot()
    assert suite.get("tests") == "1" and suite.get("failures") == "1"
    assert "cross_track_rms_m" in (suite.find("testcase/failure").get("message") or "")  # type: ignore[union-attr]


@pytest.mark.long(reason="kartci runs end to end")
def test_report_rebuilds_from_logs_alone(tmp_path: Path) -> None:
    out, base = tmp_path / "out", tmp_path / "baselines"
    base.mkdir()
    assert kartci("run", "line_straight", *SHORT, "--out", out, "--baselines", base
                  ).returncode == 0
    metrics = (out / "line_straight" / "metrics.json").read_bytes()
    for name in ("metrics.json",):
        (out / "line_straight" / name).unlink()
    for name in ("report.html", "summary.md", "summary.json", "junit.xml"):
        (out / name).unlink()
    p = kartci("report", out, "--baselines", base)
    assert p.returncode == 0, p.stderr
    assert (out / "line_straight" / "metrics.json").read_bytes() == metrics
    for name in ("report.html", "summary.md", "summary.json", "junit.xml"):
        assert (out / name).exists()


def test_report_on_a_folder_without_logs(tmp_path: Path) -> None:
    line = _one_clean_line(kartci("report", tmp_path))
    assert "no <scenario>/run.mcap logs found" in line


@pytest.mark.parametrize("cmd", [["show", "line_circle", "--set", "seed=3"], ["schema"]])
def test_show_and_schema_print_json(cmd: list[str]) -> None:
    p = kartci(*cmd)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc.get("seed", 3) == 3


def test_characterise_writes_csv_and_plot(tmp_path: Path) -> None:
    p = kartci("characterise", "--out", tmp_path, "--fovs", "0.75,1.2", "--step-m", "0.001")
    assert p.returncode == 0, p.stderr
    assert "geometric: y = " in p.stdout
    header = (tmp_path / "sweep.csv").read_text().splitlines()[0]
    assert header.startswith("offset_m,left,right,difference")
    assert "<svg" in (tmp_path / "characterisation.html").read_text()


@pytest.mark.long(reason="several kartci runs end to end")
def test_bad_inputs_found_in_review_are_one_line_each(tmp_path: Path) -> None:
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"\xff\xfe\x00")
    assert "not a UTF-8 text file" in _one_clean_line(kartci("show", binary))
    afile = tmp_path / "afile"
    afile.write_text("x")
    _one_clean_line(kartci("run", "line_straight", *SHORT, "--out", afile / "sub"))
    assert "no such folder" in _one_clean_line(kartci("report", tmp_path, "--baselines",
                                                      tmp_path / "typo"))
    crit = tmp_path / "crit.yaml"
    crit.write_text((SCENARIOS / "line_straight.yaml").read_text()
                    + "\n" + "tags: []\n")
    assert "unknown metrics: cross_track_maxx_m" in _one_clean_line(kartci(
        "run", crit, "--set", "criteria={cross_track_maxx_m: {max: 1}}", "--out", tmp_path / "o"))


@pytest.mark.long(reason="several kartci runs end to end")
def test_a_failed_run_is_marked_and_never_becomes_a_baseline(tmp_path: Path) -> None:
    out, base = tmp_path / "out", tmp_path / "baselines"
    base.mkdir()
    assert kartci("run", "line_straight", *SHORT, "--out", out, "--baselines", base
                  ).returncode == 0
    good = (out / "line_straight" / "metrics.json").read_bytes()
    # a broken URDF path makes the run itself fail
    bad = kartci("run", "line_straight", *SHORT, "--set", "agents.lt0.model.urdf=nope.urdf",
                 "--out", out, "--baselines", base)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr + bad.stdout
    assert (out / "line_straight" / "metrics.json").read_bytes() == good  # kept...
    assert (out / "line_straight" / "error.json").exists()  # ...but marked stale
    assert kartci("report", out, "--baselines", base).returncode == 2
    refused = _one_clean_line(kartci("baseline", "update", out, "--baselines", base))
    assert "last run of this scenario failed" in refused
    assert not any(base.iterdir())


def test_corrupt_files_for_baseline_update(tmp_path: Path) -> None:
    out, base = tmp_path / "out", tmp_path / "baselines"
    (out / "a").mkdir(parents=True)
    (out / "b").mkdir(parents=True)
    (out / "a" / "metrics.json").write_text('{"metrics": {"x": {"value": 1.0}}}')
    (out / "b" / "metrics.json").write_text('{"metrics": {"x": {"value": "abc"}}}')
    for name in ("a", "b"):
        (out / name / "run.mcap").write_bytes(b"")  # complete, as far as update checks
    line = _one_clean_line(kartci("baseline", "update", out, "--baselines", base))
    assert "no manifest.json" in line  # not from `kartci run`: name the scenarios
    (out / "manifest.json").write_text('{"command": "run", "scenarios": ["a", "b"]}')
    line = _one_clean_line(kartci("baseline", "update", out, "--baselines", base))
    assert "b/metrics.json" in line
    assert not base.exists() or not any(base.iterdir())  # nothing half-written
    (out / "b" / "metrics.json").write_text('{"metrics": {"x": {"value": 2.0}}}')
    base.mkdir(exist_ok=True)
    (base / "a.json").write_text('{"metrics": {"x": {"value": 1, "tolerance": NaN, '
                                 '"direction": "lower"}}}')
    assert "a.json: malformed baseline" in _one_clean_line(
        kartci("baseline", "update", out, "--baselines", base))


@pytest.mark.long(reason="kartci runs end to end")
def test_list_shows_origins_and_survives_a_bad_file_and_a_broken_link(tmp_path: Path) -> None:
    (tmp_path / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    scen = tmp_path / "scenarios"
    scen.mkdir()
    (scen / "ours.yaml").write_text((SCENARIOS / "line_straight.yaml").read_text()
                                    .replace("description: Line tracker", "description: Ours"))
    (scen / "broken.yaml").write_text("description: [oops\n")
    (scen / "gone.yaml").symlink_to(tmp_path / "nowhere.yaml")
    p = kartci("list", cwd=tmp_path)
    assert p.returncode == 2 and "Traceback" not in p.stdout + p.stderr
    (line,) = p.stderr.strip().splitlines()
    assert "2 of" in line and "broken, gone" in line
    rows = {ln.split()[0]: ln.split()[1:] for ln in p.stdout.splitlines()[1:] if ln.strip()
            and not ln.startswith(" " * 10)}
    assert rows["ours"][:2] == ["project", "Ours"]
    assert rows["line_circle"][0] == "built-in" and rows["mpcc_lap"][0] == "built-in"
    assert rows["broken"][:2] == ["project", "error:"] and "broken.yaml" in p.stdout
    assert rows["gone"][:2] == ["project", "error:"] and "broken link" in p.stdout

    (scen / "broken.yaml").unlink()
    (scen / "gone.yaml").unlink()
    ok = kartci("list", cwd=tmp_path)
    assert ok.returncode == 0 and ok.stderr == ""


def test_list_without_any_scenario_is_one_line(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    from kartci import project
    from kartci.cli import main

    monkeypatch.setattr(project, "BUILTIN_SCENARIOS", tmp_path / "no_builtins")
    monkeypatch.setenv("KARTCI_ROOT", str(tmp_path))
    monkeypatch.setattr(sys, "argv", ["kartci", "list"])
    with pytest.raises(SystemExit) as exit_:
        main()
    assert exit_.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("kartci: error: no scenarios found") and "kartci init" in line


def test_plugins_lists_every_registered_one_with_its_module(tmp_path: Path) -> None:
    from kartci import core

    (tmp_path / "kartci.toml").write_text('plugins = ["team_worlds"]\n')
    (tmp_path / "team_worlds.py").write_text(
        "from kartci.core import WorldKind, lazy, register\n"
        "from kartci.worlds.line_lab import LineLabWorld\n"
        "register(WorldKind('team_floor', LineLabWorld,\n"
        "                   lazy('kartci.worlds.line_lab.world:LineLab'),\n"
        "                   'our lab floor, taped'))\n")
    p = kartci("plugins", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    for reg in core.REGISTRIES:
        words = reg.what.split()  # "controller", "robot kind", ...
        for name in reg.names():
            assert any(ln.split()[:len(words) + 1] == [*words, name] for ln in lines), name
    assert "line_pid" in p.stdout and ("kartci.robots.line_tracker.controllers (entry point of "
                                      "kartci") in p.stdout
    team = next(ln for ln in p.stdout.splitlines() if "team_floor" in ln)
    assert team.split()[:2] == ["world", "kind"] and "our lab floor, taped" in team
    assert team.rstrip().endswith("team_worlds")
