"""Issue 24, defect 1: data files stay inside the project and kartci's data, and a file that
fails to parse is named by file, line and column, never quoted into an artifact.

Each test runs the CLI as a user does, in a project of its own (`tmp_path/proj`) with a
secret-looking file beside it (`tmp_path/outside/secret.csv`), as `/etc/passwd` or a
credentials file would be on a CI runner.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest
from helpers import kartci

from kartci.project import BUILTIN_MODELS, BUILTIN_SCENARIOS, BUILTIN_SIMS

SECRET = "SECRET_TOKEN_4711"
OUTSIDE = "is outside the project and kartci's data (pass --allow-outside-paths to use it)"
QUICK = ("--set", "duration_s=1")


@pytest.fixture
def proj(tmp_path: Path) -> Path:
    """A project (kartci.toml, worlds/, models/, scenarios/) and a secret file outside it."""
    root = tmp_path / "proj"
    for folder in ("worlds/my", "models", "scenarios"):
        (root / folder).mkdir(parents=True)
    (root / "kartci.toml").write_text("")
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "secret.csv").write_text(f"{SECRET}=hunter2,1,2,3\n")
    return root


def _one_line(p: subprocess.CompletedProcess[str]) -> str:
    """The single stderr line of a refused command (exit 2, no traceback)."""
    assert p.returncode == 2, p.stdout + p.stderr
    assert "Traceback" not in p.stdout + p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    return lines[0]


def _leaks(out: Path, p: subprocess.CompletedProcess[str]) -> list[str]:
    """Every artifact under `out` (error.json, junit.xml, reports, summaries, run.json) and
    the command's own output that holds the secret."""
    files = [f for f in out.rglob("*") if f.is_file()] if out.exists() else []
    return ([str(f) for f in files if SECRET.encode() in f.read_bytes()]
            + [name for name, text in (("stdout", p.stdout), ("stderr", p.stderr))
               if SECRET in text])


@pytest.mark.parametrize("ci", ["true", ""])
def test_an_absolute_track_path_outside_the_project_is_refused(proj: Path, ci: str) -> None:
    """The issue's reproduction (`--set world.track=/etc/passwd --out out`), in and out of CI."""
    secret = proj.parent / "outside" / "secret.csv"
    p = kartci("run", "kart_manual", *QUICK, "--set", f"world.track={secret}", "--out", "out",
               cwd=proj, env={"CI": ci})
    assert _one_line(p) == f"kartci: error: world.track: {secret} {OUTSIDE}"
    assert not (proj / "out").exists()


def test_a_dotdot_track_path_is_refused(proj: Path) -> None:
    """`..` out of the project, from `--set` (relative to the working directory) and from a
    world file (relative to the world folders)."""
    p = kartci("show", "kart_manual", "--set", "world.track=../outside/secret.csv", cwd=proj)
    assert _one_line(p) == f"kartci: error: world.track: ../outside/secret.csv {OUTSIDE}"
    (proj / "worlds" / "my" / "up.yaml").write_text(
        "kind: hall\nsize_m: [32.0, 20.0]\ntrack: ../../../outside/secret.csv\n")
    p = kartci("show", "kart_manual", "--set", "world=my/up", cwd=proj)
    assert _one_line(p) == ("kartci: error: world data file '../../../outside/secret.csv': "
                            "expected a name relative to the search path (no absolute path, "
                            "no '..')")


def test_a_symlink_out_of_worlds_is_refused(proj: Path) -> None:
    """A track and a world file in worlds/ that are links to a file outside the project."""
    secret = (proj.parent / "outside" / "secret.csv").resolve()
    link = proj / "worlds" / "my" / "track.csv"
    link.symlink_to(secret)
    p = kartci("show", "kart_manual", "--set", "world.track=my/track.csv", cwd=proj)
    found = proj.resolve() / "worlds" / "my"  # as found on the search path
    assert _one_line(p) == (f"kartci: error: world data file 'my/track.csv': "
                            f"{found / 'track.csv'} (a link to {secret}) {OUTSIDE}")
    hall = proj / "worlds" / "my" / "hall.yaml"
    hall.symlink_to(secret)
    p = kartci("show", "kart_manual", "--set", "world=my/hall", cwd=proj)
    assert _one_line(p) == (f"kartci: error: world 'my/hall': {found / 'hall.yaml'}"
                            f" (a link to {secret}) {OUTSIDE}")


@pytest.mark.long(reason="kartci runs end to end")
def test_allow_outside_paths_lets_an_outside_track_through(proj: Path) -> None:
    """With the flag, a valid track outside the project is run like any other."""
    track = proj.parent / "outside" / "hall_track.csv"
    shutil.copy(BUILTIN_SIMS / "winti" / "track.csv", track)
    p = kartci("run", "kart_manual", *QUICK, "--set", "criteria={}", "--set",
               f"world.track={track}", "--out", "out", "--allow-outside-paths", cwd=proj)
    assert p.returncode == 0, p.stderr
    assert (proj / "out" / "kart_manual@track=hall_track" / "run.mcap").is_file()


GOKART = BUILTIN_MODELS / "gokart"
MASS_LINE = (GOKART / "params.yaml").read_text().splitlines().index(
    next(x for x in (GOKART / "params.yaml").read_text().splitlines()
         if x.startswith("mass_kg:"))) + 1
BAD_FILES = {
    # a track whose first row is a secret: numpy's message quoted it
    "track CSV": ("worlds/my/track.csv", f"{SECRET}=hunter2,1,2,3\n0,0,1,1\n",
                  ["kart_manual", *QUICK, "--set", "world.track=my/track.csv"],
                  "worlds/my/track.csv:1:1: not a TUMFTM track CSV "
                  "(x_m,y_m,w_tr_right_m,w_tr_left_m)"),
    # a world whose broken line holds a secret: the YAML problem quoted the value
    "world YAML": ("worlds/my/w.yaml", f"kind: hall\nsize_m: [32.0, 20.0]\n"
                   f"track: !!float {SECRET}\n",
                   ["kart_manual", *QUICK, "--set", "world=my/w"],
                   "worlds/my/w.yaml:3:8: not a valid !!float"),
    # a scenario with a tag naming a secret: the tag was quoted
    "scenario YAML": ("scenarios/q.yaml", f"description: !{SECRET} x\n", ["q"],
                      "scenarios/q.yaml:1:14: could not determine a constructor for the tag"),
    # a model with a bad value: pydantic's message showed the value
    "model file": ("models/mykart/params.yaml",
                   (GOKART / "params.yaml").read_text().replace("\nmass_kg:",
                                                                f"\nmass_kg: {SECRET} #"),
                   ["kart_manual", *QUICK, "--set", "agents.kart0.model=mykart"],
                   # the model file's own line and key (`mass_kg:` is on the same line)
                   f"models/mykart/params.yaml:{MASS_LINE}:1: mass_kg: Input should be a valid "
                   "number, unable to parse string as a number"),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_file_contents_never_reach_an_artifact(proj: Path, case: str) -> None:
    """A file that fails to parse is named by place in stderr and every artifact, under CI,
    and its contents are in none of them."""
    rel, text, args, message = BAD_FILES[case]
    bad = proj / rel
    bad.parent.mkdir(parents=True, exist_ok=True)
    bad.write_text(text)
    if case == "model file":
        shutil.copy(GOKART / "bumblebee.urdf", bad.parent)
    p = kartci("run", *args, "--out", "out", cwd=proj, env={"CI": "true"})
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stdout + p.stderr
    assert message in " ".join(p.stderr.split())  # rich wraps lines at 160 columns in CI
    if case == "track CSV":  # fails in the run: the artifacts are written, naming the place
        for name in ("error.json", "junit.xml", "summary.md", "report.html"):
            assert message in next((proj / "out").rglob(name)).read_text(), name
    assert _leaks(proj / "out", p) == []


LOG = BUILTIN_SCENARIOS / "logs" / "kart_manual_ps4.mcap"
SCENARIO_WITH_LOG = """description: q
world: winti/hall
duration_s: 1.0
agents:
  kart0:
    model: gokart
    controller: {type: manual, mapping: ps4, source: {log: LOG, topic: /kart0/joy}}
"""


def _source_log(proj: Path) -> tuple[list[str], str]:
    """A scenario of the project naming a log beside the secret through `..`."""
    (proj / "scenarios" / "q.yaml").write_text(
        SCENARIO_WITH_LOG.replace("LOG", "../../outside/x.mcap"))
    shutil.copy(LOG, proj.parent / "outside" / "x.mcap")
    return (["show", "q"], f"agents.kart0.controller.source.log: "
                           f"{(proj.parent / 'outside' / 'x.mcap').resolve()} {OUTSIDE}")


def _mapping_path(proj: Path) -> tuple[list[str], str]:
    """A joystick mapping named by a path out of the project."""
    return (["show", "kart_manual", "--set",
             "agents.kart0.controller.mapping=../outside/pad.yaml"],
            f"agents.kart0.controller.mapping: ../outside/pad.yaml {OUTSIDE}")


def _mapping_link(proj: Path) -> tuple[list[str], str]:
    """A mapping by name whose file in the project's models/gokart/joy/ links out of it."""
    joy = proj / "models" / "gokart" / "joy"
    joy.mkdir(parents=True)
    secret = (proj.parent / "outside" / "secret.csv").resolve()
    (joy / "evil.yaml").symlink_to(secret)
    return (["show", "kart_manual", "--set", "agents.kart0.controller.mapping=evil"],
            f"agents.kart0.controller.mapping: {proj.resolve() / 'models/gokart/joy/evil.yaml'}"
            f" (a link to {secret}) {OUTSIDE}")


def _node_map(proj: Path) -> tuple[list[str], str]:
    """The localization node's map (a PLY) given as an absolute path out of the project."""
    secret = proj.parent / "outside" / "secret.csv"
    return (["show", "localization_lap", "--set", f"agents.kart0.nodes.localization.map={secret}"],
            f"agents.kart0.nodes.localization.map: {secret} {OUTSIDE}")


def _profile_track(proj: Path) -> tuple[list[str], str]:
    """An import profile (of the project) whose track is the secret, relative to the profile."""
    (proj / "p.yaml").write_text("pose: {topic: /kart0/odom}\ntrack: ../outside/secret.csv\n")
    return (["score", str(LOG), "--profile", "p.yaml", "--out", "out"],
            f"p.yaml: track: ../outside/secret.csv {OUTSIDE}")


@pytest.mark.parametrize("make", [_source_log, _mapping_path, _mapping_link, _node_map,
                                  _profile_track])
def test_files_read_at_run_time_are_contained_at_load_time(proj: Path, make: Any) -> None:
    """Issue 24, defect 1, the files read only when the run starts (a controller's source
    log and joystick mapping, a node's map, a profile's track) were never checked: each is
    refused when the scenario or profile is loaded, as world.track is, and nothing runs."""
    args, expected = make(proj)
    p = kartci(*args, cwd=proj)
    assert _one_line(p) == f"kartci: error: {expected}"
    assert not list(proj.rglob("*.mcap"))  # nothing ran
    assert _leaks(proj / "out", p) == []


@pytest.mark.long(reason="several kartci runs end to end")
def test_a_source_log_inside_the_project_or_allowed_keeps_working(proj: Path) -> None:
    """A scenario naming a log inside the project (relative to the scenario file) resolves to
    it, as the shipped kart_manual's does; one outside runs with --allow-outside-paths."""
    (proj / "logs").mkdir()
    shutil.copy(LOG, proj / "logs" / "x.mcap")
    (proj / "scenarios" / "q.yaml").write_text(SCENARIO_WITH_LOG.replace("LOG", "../logs/x.mcap"))
    p = kartci("show", "q", cwd=proj)
    assert p.returncode == 0, p.stderr
    assert f'"log": "{(proj / "logs" / "x.mcap").resolve()}"' in p.stdout
    args, _ = _source_log(proj)
    assert kartci(*args, "--allow-outside-paths", cwd=proj).returncode == 0
    p = kartci("show", "kart_manual", cwd=proj)
    assert f'"log": "{LOG}"' in p.stdout
