"""Issue 24, bad input: duplicate keys in any YAML a command reads, and file inputs that are not
regular files or hold numbers a float cannot (defects 3 and 8). Each runs the real CLI and
asserts one line naming the file (never its contents) and exit 2."""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest
from helpers import ROOT, kartci

LOGS = ROOT / "scenarios" / "logs"
HALL = (ROOT / "sims" / "winti" / "hall.yaml").read_text(encoding="utf-8")
PARAMS = (ROOT / "models" / "gokart" / "params.yaml").read_text(
    encoding="utf-8")
PS4 = (ROOT / "models" / "gokart" / "joy" / "ps4.yaml").read_text(
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
    """`:12:1:`: file, line and column."""
    return rf":{line}:{column}:"


def _scenario_top(tmp: Path) -> Case:
    _project(tmp)
    return (["show", "q"],
            rf"scenarios/q\.yaml{_place(12, 1)} duplicate key \(first at line 9\)$")


def _scenario_nested(tmp: Path) -> Case:
    path = _project(tmp)
    text = path.read_text(encoding="utf-8").replace("    start: {along_m: 0.0}\n",
                                                    "    start: {along_m: 0.0, along_m: 5.0}\n")
    path.write_text(text.replace("criteria: {}\n", ""), encoding="utf-8")
    return (["show", "q"],
            rf"scenarios/q\.yaml{_place(7, 27)} duplicate key \(first at line 7\)$")


def _world(tmp: Path) -> Case:
    path = _project(tmp, world="dup")
    path.write_text(path.read_text(encoding="utf-8").replace("criteria: {}\n", ""),
                    encoding="utf-8")
    (tmp / "worlds").mkdir()
    (tmp / "worlds" / "dup.yaml").write_text(HALL + "floor_friction: 0.1\n", encoding="utf-8")
    first = HALL.splitlines().index(next(x for x in HALL.splitlines()
                                         if x.startswith("floor_friction:"))) + 1
    last = len(HALL.splitlines()) + 1
    return (["show", "q"], rf"worlds/dup\.yaml{_place(last, 1)} duplicate key "
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
                           rf" duplicate key \(first at line {first}\)$")


def _mapping(tmp: Path) -> Case:
    (tmp / "pad.yaml").write_text(PS4 + "axes: {}\n", encoding="utf-8")
    first = next(i for i, x in enumerate(PS4.splitlines(), 1) if x.startswith("axes:"))
    return (["replay", LOGS / "kart_manual_ps4.mcap", "--mapping", "pad.yaml", "--set",
             "duration_s=1", "--out", "out"],
            rf"pad\.yaml{_place(len(PS4.splitlines()) + 1, 1)} duplicate key "
            rf"\(first at line {first}\)$")


def _profile(tmp: Path) -> Case:
    (tmp / "p.yaml").write_text("name: p\npose: {topic: /a}\nimu: {topic: /b}\n"
                                "pose: {topic: /c}\n", encoding="utf-8")
    return (["score", LOGS / "kart_manual_ps4.mcap", "--profile", "p.yaml", "--out", "out"],
            rf"p\.yaml{_place(4, 1)} duplicate key \(first at line 2\)$")


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


@pytest.mark.parametrize(("number", "shown"), [("9" * 400, "400-digit integer"),
                                               ("1e999", "float overflow")])
def test_history_number_out_of_range_names_file_and_field(tmp_path: Path, number: str,
                                                          shown: str) -> None:
    """Defect 8: a 400-digit integer in a summary gave "internal error: OverflowError"."""
    summary = tmp_path / "c1.json"
    summary.write_text('{"scenarios": {"q": {"metrics": {"cte": {"value": ' + number + "}}}}}",
                       encoding="utf-8")
    line = _one_error_line(kartci("history", summary, "--out", "h", cwd=tmp_path))
    assert line == (f"{summary}: scenarios.q.metrics.cte.value: a number out of range (beyond "
                    "a float's ±1.8e308)"), shown
    assert not (tmp_path / "h").exists()


def _fifo(tmp: Path, name: str) -> Path:
    path = tmp / name
    os.mkfifo(path)
    return path


def _sparse(tmp: Path, name: str, n_bytes: int) -> Path:
    path = tmp / name
    with path.open("wb") as f:
        f.truncate(n_bytes)  # no data blocks: cheap on any file system with holes
    return path


def _inputs() -> list[tuple[str, Callable[[Path], tuple[list[str | Path], str]]]]:
    """(name, make) where make(tmp) gives the CLI arguments and the error line expected."""
    log = LOGS / "kart_manual_ps4.mcap"
    fifo = "not a regular file (a FIFO)"

    def history_fifo(t: Path) -> tuple[list[str | Path], str]:
        return ["history", _fifo(t, "c1.json"), "--out", "h"], f"{t}/c1.json: {fifo}"

    def history_zero(t: Path) -> tuple[list[str | Path], str]:
        return (["history", "/dev/zero", "--out", "h"],
                "/dev/zero: not a regular file (a character device)")

    def history_huge(t: Path) -> tuple[list[str | Path], str]:
        big = _sparse(t, "c1.json", (64 << 20) + 1)
        return (["history", big, "--out", "h"],
                f"{big}: {(64 << 20) + 1} bytes, more than the 64 MiB allowed")

    def replay_fifo(t: Path) -> tuple[list[str | Path], str]:
        return (["replay", _fifo(t, "in.mcap"), "--set", "duration_s=1", "--out", "out"],
                f"{t}/in.mcap: {fifo}")

    def extract_fifo(t: Path) -> tuple[list[str | Path], str]:
        return (["extract", _fifo(t, "in.mcap"), "-t", "/kart0/joy", "--out", "x.mcap"],
                f"{t}/in.mcap: {fifo}")

    def rosbag2_with_fifo(t: Path) -> tuple[list[str | Path], str]:
        (t / "bag").mkdir()
        (t / "bag" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n",
                                                 encoding="utf-8")
        _fifo(t / "bag", "bag_0.mcap")
        return (["extract", t / "bag", "-t", "/a", "--out", "x.mcap"],
                f"{t}/bag: bag_0.mcap in it: {fifo}")

    def diff_fifo(t: Path) -> tuple[list[str | Path], str]:
        return ["diff", log, _fifo(t, "b.mcap")], f"{t}/b.mcap: {fifo}"

    def mapping_fifo(t: Path) -> tuple[list[str | Path], str]:
        return (["replay", log, "--mapping", _fifo(t, "pad.yaml"), "--set", "duration_s=1",
                 "--out", "out"], f"{t}/pad.yaml: {fifo}")

    def profile_fifo(t: Path) -> tuple[list[str | Path], str]:
        return (["score", log, "--profile", _fifo(t, "p.yaml"), "--out", "out"],
                f"{t}/p.yaml: {fifo}")

    return [(f.__name__, f) for f in (history_fifo, history_zero, history_huge, replay_fifo,
                                      extract_fifo, rosbag2_with_fifo, diff_fifo, mapping_fifo,
                                      profile_fifo)]


@pytest.mark.parametrize("make", [m for _, m in _inputs()], ids=[n for n, _ in _inputs()])
def test_file_inputs_must_be_bounded_regular_files(
        tmp_path: Path, make: Callable[[Path], tuple[list[str | Path], str]]) -> None:
    """Defect 8: history read /dev/zero without a limit, and history and replay hung on a
    FIFO. Every file a command reads is a regular file (a log without a size cap, a rosbag2
    folder of regular files) within its bound, or one line naming it and exit 2."""
    args, expected = make(tmp_path)
    line = _one_error_line(kartci(*args, cwd=tmp_path))
    assert expected in line, line
    assert not (tmp_path / "out" / "report.html").exists()


def test_baseline_fifo_is_an_error_not_a_hang(tmp_path: Path) -> None:
    """Defect 8, baselines: a FIFO where a baseline belongs hung the judging of a run."""
    (tmp_path / "bl").mkdir()
    _fifo(tmp_path / "bl", "kart_manual.json")
    proc = kartci("run", "kart_manual", "--set", "duration_s=1", "--baselines", "bl",
                  "--out", "out", cwd=tmp_path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "kart_manual: ERROR: bl/kart_manual.json: not a regular file (a FIFO)" \
        in proc.stdout


def _line_of(text: str, start: str) -> int:
    """The 1-based line of `text` that starts with `start`."""
    return next(i for i, x in enumerate(text.splitlines(), 1) if x.startswith(start))


def _bad_world(tmp: Path) -> tuple[list[str | Path], str]:
    (tmp / "worlds" / "my").mkdir(parents=True)
    hall = re.sub(r"(?m)^floor_friction:.*$", "floor_friction: 99", HALL)
    (tmp / "worlds" / "my" / "hall.yaml").write_text(hall, encoding="utf-8")
    return (["show", "q"], f"{tmp}/worlds/my/hall.yaml:{_line_of(hall, 'floor_friction:')}:1: "
                           "floor_friction: must be at most 10")


def _bad_model(tmp: Path) -> tuple[list[str | Path], str]:
    (tmp / "models" / "mykart").mkdir(parents=True)
    params = re.sub(r"(?m)^mass_kg:.*$", "mass_kg: -5", PARAMS)
    (tmp / "models" / "mykart" / "params.yaml").write_text(params, encoding="utf-8")
    urdf = ROOT / "models" / "gokart" / "bumblebee.urdf"
    (tmp / "models" / "mykart" / "bumblebee.urdf").write_bytes(urdf.read_bytes())
    return (["show", "q", "--set", "agents.kart0.model=mykart"],
            f"{tmp}/models/mykart/params.yaml:{_line_of(params, 'mass_kg:')}:1: mass_kg: must "
            "be more than 0 kg")


def _bad_scenario(tmp: Path) -> tuple[list[str | Path], str]:
    path = tmp / "scenarios" / "q.yaml"
    path.write_text(path.read_text(encoding="utf-8").replace("along_m: 0.0", "along_m: -1"),
                    encoding="utf-8")
    return ["show", "q"], f"{path}:7:13: agents.kart0.start.along_m: must be at least 0 m"


@pytest.mark.parametrize("make", [_bad_world, _bad_model, _bad_scenario])
def test_a_bad_value_names_the_file_and_line_it_came_from(
        tmp_path: Path, make: Callable[[Path], tuple[list[str | Path], str]]) -> None:
    """A bad value in a world or model file was reported against the scenario file, and no
    validation error had a line: now the file the value was written in, its line and column
    and the key as written there (never the value: the file may be anything)."""
    scenario = _project(tmp_path, world="my/hall" if make is _bad_world else "winti/hall")
    scenario.write_text(scenario.read_text(encoding="utf-8").replace("criteria: {}\n", ""),
                        encoding="utf-8")
    args, expected = make(tmp_path)
    assert _one_error_line(kartci(*args, cwd=tmp_path)) == expected


@pytest.mark.parametrize(("make", "reason"), [
    (lambda t: _fifo(t, "pyproject.toml"), "not a regular file (a FIFO)"),
    (lambda t: _sparse(t, "pyproject.toml", 1 << 30),
     f"{1 << 30} bytes, more than the 4 MiB allowed")], ids=["fifo", "1GB"])
def test_the_project_file_is_a_bounded_regular_file(tmp_path: Path, make: Callable[[Path], Path],
                                                    reason: str) -> None:
    """kartci.toml / pyproject.toml were read whole with read_text: a FIFO would hang every
    command and 1 GB be read into memory. Now one line naming the file, exit 2."""
    path = make(tmp_path)
    assert _one_error_line(kartci("list", cwd=tmp_path)) == f"{path}: {reason}"


@pytest.mark.parametrize(("scenario", "key", "name", "reason"), [
    ("kart_manual", "agents.kart0.model.urdf", "k.urdf", "not a regular file (a FIFO)"),
    ("localization_lap", "agents.kart0.nodes.localization.map", "m.ply",
     "cannot read the map: not a regular file (a FIFO)")], ids=["urdf", "ply"])
def test_urdf_and_map_are_read_as_bounded_regular_files(tmp_path: Path, scenario: str, key: str,
                                                        name: str, reason: str) -> None:
    """A URDF and a PLY map were read unbounded: a FIFO hung the run. Now the run fails at
    once naming the file (exit 2)."""
    (tmp_path / "kartci.toml").write_text("", encoding="utf-8")
    fifo = _fifo(tmp_path, name)
    proc = kartci("run", scenario, "--set", "duration_s=0.1", "--set", f"{key}={fifo}",
                  "--out", "out", cwd=tmp_path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert f"{scenario}: ERROR: {fifo}: {reason}" in proc.stdout


@pytest.mark.long(reason="kartci runs end to end")
def test_box_and_hall_sizes_must_be_positive(tmp_path: Path) -> None:
    """`size_m` of a box (and of a hall) took any length in ±1e4 m, negative too: an edge
    length is now more than 0."""
    _project(tmp_path)
    box = "world.obstacles=[{center_m: [5.0, 5.0], size_m: [-1.0, 1.0, 1.0]}]"
    line = _one_error_line(kartci("show", "kart_manual", "--set", box, cwd=tmp_path))
    assert line.endswith("kart_manual.yaml: world.obstacles.0.size_m.0 (from --set): must be "
                         "more than 0 m (got -1.0)")
    (tmp_path / "worlds").mkdir()
    hall = re.sub(r"(?m)^size_m:.*$", "size_m: [32.0, -20.0]", HALL)
    (tmp_path / "worlds" / "neg.yaml").write_text(hall, encoding="utf-8")
    line = _one_error_line(kartci("show", "kart_manual", "--set", "world=neg", cwd=tmp_path))
    row = _line_of(hall, "size_m:")
    at = f"{row}:{hall.splitlines()[row - 1].index('-20.0') + 1}"  # the item's own column
    assert line == f"{tmp_path}/worlds/neg.yaml:{at}: size_m.1: must be more than 0 m"
