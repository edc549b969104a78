"""Issue 24, bad input: duplicate keys in any YAML a command reads, and file inputs that are not
regular files or hold numbers a float cannot (defects 3 and 8). Each runs the real CLI and
asserts one line naming the file (never its contents) and exit 2."""

from __future__ import annotations

import re
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest
from helpers import ROOT, kartci

LOGS = ROOT / "kartci" / "data" / "scenarios" / "logs"
HALL = (ROOT / "kartci" / "data" / "worlds" / "winti" / "hall.yaml").read_text(encoding="utf-8")
PARAMS = (ROOT / "kartci" / "data" / "models" / "gokart" / "params.yaml").read_text(
    encoding="utf-8")
PS4 = (ROOT / "kartci" / "data" / "models" / "gokart" / "joy" / "ps4.yaml").read_text(
    encoding="utf-8")

Case = tuple[list[str | Path], str]  # CLI arguments, a regular expression the error line matches
SOURCE = f"{{log: {LOGS}/kart_manual_ps4.mcap, topic: /kart0/joy}}"
# the case: criteria that fail (two laps in one second), then `criteria: {}` (line 12)
SCENARIO = f"""description: q
world: WORLD
duration_s: 1.0
agents:
  kart0:
    model: MODEL
    start: {{along_m: 0.0}}
    controller: {{type: manual, mapping: ps4, source: {SOURCE}}}
criteria:
  laps_completed: {{min: 2}}
  collisions: {{equal: 0}}
criteria: {{}}
"""


def _one_error_line(proc: subprocess.CompletedProcess[str]) -> str:
    """The single line a bad input gives, after checking the exit code."""
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("kartci: error: "), proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0].removeprefix("kartci: error: ")


def _project(tmp: Path, world: str = "winti/hall", model: str = "gokart") -> Path:
    (tmp / "kartci.toml").write_text("", encoding="utf-8")
    (tmp / "scenarios").mkdir()
    scenario = tmp / "scenarios" / "q.yaml"
    scenario.write_text(SCENARIO.replace("WORLD", world).replace("MODEL", model),
                        encoding="utf-8")
    return scenario


def _place(line: int, column: int) -> str:
    """`:12:1:` (file, line, column) or `: line 12:`, the form before columns were added."""
    return rf"(:{line}:{column}:|: line {line}:)"


def _scenario_top(tmp: Path) -> Case:
    _project(tmp)
    return (["show", "q"],
            rf"scenarios/q\.yaml{_place(12, 1)} duplicate key 'criteria' \(first at line 9\)$")


def _scenario_nested(tmp: Path) -> Case:
    path = _project(tmp)
    text = path.read_text(encoding="utf-8").replace("    start: {along_m: 0.0}\n",
                                                    "    start: {along_m: 0.0, along_m: 5.0}\n")
    path.write_text(text.replace("criteria: {}\n", ""), encoding="utf-8")
    return (["show", "q"],
            rf"scenarios/q\.yaml{_place(7, 29)} duplicate key 'along_m' \(first at line 7\)$")


def _world(tmp: Path) -> Case:
    path = _project(tmp, world="dup")
    path.write_text(path.read_text(encoding="utf-8").replace("criteria: {}\n", ""),
                    encoding="utf-8")
    (tmp / "worlds").mkdir()
    (tmp / "worlds" / "dup.yaml").write_text(HALL + "floor_friction: 0.1\n", encoding="utf-8")
    first = HALL.splitlines().index(next(x for x in HALL.splitlines()
                                         if x.startswith("floor_friction:"))) + 1
    last = len(HALL.splitlines()) + 1
    return (["show", "q"], rf"worlds/dup\.yaml{_place(last, 1)} duplicate key 'floor_friction' "
                           rf"\(first at line {first}\)$")


def _model(tmp: Path) -> Case:
    path = _project(tmp, model="dupkart")
    path.write_text(path.read_text(encoding="utf-8").replace("criteria: {}\n", ""),
                    encoding="utf-8")
    (tmp / "models" / "dupkart").mkdir(parents=True)
    key = next(x for x in PARAMS.splitlines() if re.match(r"^\w+:", x)).split(":")[0]
    (tmp / "models" / "dupkart" / "params.yaml").write_text(PARAMS + f"{key}: 1\n",
                                                            encoding="utf-8")
    first = next(i for i, x in enumerate(PARAMS.splitlines(), 1) if x.startswith(f"{key}:"))
    return (["show", "q"], rf"models/dupkart/params\.yaml{_place(len(PARAMS.splitlines()) + 1, 1)}"
                           rf" duplicate key '{key}' \(first at line {first}\)$")


def _mapping(tmp: Path) -> Case:
    (tmp / "pad.yaml").write_text(PS4 + "axes: {}\n", encoding="utf-8")
    first = next(i for i, x in enumerate(PS4.splitlines(), 1) if x.startswith("axes:"))
    return (["replay", LOGS / "kart_manual_ps4.mcap", "--mapping", "pad.yaml", "--set",
             "duration_s=1", "--out", "out"],
            rf"pad\.yaml{_place(len(PS4.splitlines()) + 1, 1)} duplicate key 'axes' "
            rf"\(first at line {first}\)$")


def _profile(tmp: Path) -> Case:
    (tmp / "p.yaml").write_text("name: p\npose: {topic: /a}\nimu: {topic: /b}\n"
                                "pose: {topic: /c}\n", encoding="utf-8")
    return (["score", LOGS / "kart_manual_ps4.mcap", "--profile", "p.yaml", "--out", "out"],
            rf"p\.yaml{_place(4, 1)} duplicate key 'pose' \(first at line 2\)$")


def _toml(tmp: Path) -> Case:
    """TOML refuses duplicates itself (tomllib); the line says where, never what."""
    (tmp / "pyproject.toml").write_text('[tool.kartci]\nscenarios = ["a"]\n'
                                        'scenarios = ["SECRET"]\n', encoding="utf-8")
    return ["list"], r"pyproject\.toml: cannot read \(Cannot overwrite a value \(at line 3, " \
                     r"column \d+\)\)$"


@pytest.mark.parametrize("make", [_scenario_top, _scenario_nested, _world, _model, _mapping,
                                  _profile, _toml])
def test_duplicate_keys_exit_2_naming_both_lines(tmp_path: Path,
                                                 make: Callable[[Path], Case]) -> None:
    """Defect 3: the last of two equal keys won silently (`criteria: {}` turned exit 1 into
    0). Now a duplicate at any level of any YAML a command reads is exit 2 with both lines."""
    args, expected = make(tmp_path)
    line = _one_error_line(kartci(*args, cwd=tmp_path))
    assert re.search(expected, line), line
    assert "SECRET" not in line and "laps_completed" not in line
    assert not (tmp_path / "out" / "report.html").exists()
