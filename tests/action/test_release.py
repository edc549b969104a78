"""The release: .github/workflows/release.yml and .ci/run run the same check
(tools/check_release.sh, measured at about 3-4 min: it builds, installs into an empty venv and
runs a scenario, so it runs there, not here); the publish job takes the files the check
uploaded; a tag publishes only the version it names; the major tag follows the newest release,
and the action runs at it (through the emulator, tests/action/composite.py)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest
import yaml
from action_project import make_project

from kartci import __version__

ROOT = Path(__file__).resolve().parents[2]
RELEASE: dict[str, Any] = yaml.safe_load((ROOT / ".github" / "workflows" / "release.yml")
                                         .read_text())
SCRIPT = "tools/check_release.sh"


def test_ci_and_the_release_workflow_run_the_same_check() -> None:
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert any(line.startswith(f"PYTHON=.venv/bin/python {SCRIPT} ") for line in ci)
    steps = RELEASE["jobs"]["check"]["steps"]
    runs = [s["run"] for s in steps if "run" in s]
    assert runs[:2] == ["python -m pip install -q -c constraints.txt build twine",
                        f"PYTHON=python {SCRIPT} dist"]
    (up,) = [s for s in steps if "upload-artifact" in s.get("uses", "")]
    (down,) = [s for s in RELEASE["jobs"]["publish"]["steps"]
               if "download-artifact" in s.get("uses", "")]
    assert up["with"]["name"] == down["with"]["name"] and up["with"]["path"] == "dist/"
    assert RELEASE["jobs"]["publish"]["needs"] == "check"
    assert RELEASE["jobs"]["publish"]["environment"]["name"] == "pypi"
    dev = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["dev"]
    assert {"build", "twine"} <= {d.split(">")[0] for d in dev}


@pytest.mark.parametrize(("tag", "ok"), [(f"v{__version__}", True), ("v9.9.9", False)])
def test_a_tag_publishes_only_the_version_it_names(tag: str, ok: bool, tmp_path: Path) -> None:
    (step,) = [s for s in RELEASE["jobs"]["check"]["steps"]
               if s.get("name") == "The tag names the built version"]
    (tmp_path / "dist").mkdir()
    for name in (f"kartci-{__version__}-py3-none-any.whl", f"kartci-{__version__}.tar.gz"):
        (tmp_path / "dist" / name).touch()
    p = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", step["run"]], cwd=tmp_path,
                       env={**os.environ, "TAG": tag}, timeout=60)
    assert (p.returncode == 0) is ok


def test_the_check_script_passes_shellcheck() -> None:
    exe = shutil.which("shellcheck", path=os.pathsep.join([str(Path(sys.executable).parent),
                                                           os.environ.get("PATH", "")]))
    if exe is None:
        pytest.skip('shellcheck not installed: pip install -e ".[dev]"')
    p = subprocess.run([exe, str(ROOT / SCRIPT), str(ROOT / ".ci" / "run")],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stdout


def _git(cwd: Path, *args: str) -> str:
    env = {**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.org",
           "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@example.org",
           "GIT_CONFIG_GLOBAL": os.devnull, "GIT_CONFIG_NOSYSTEM": "1"}
    p = subprocess.run(["git", *args], cwd=cwd, env=env, capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 0, p.stdout + p.stderr
    return p.stdout.strip()


def _move_major_tag(clone: Path, origin: Path, tag: str) -> str:
    """The release workflow's step, in a clone checked out at `tag` (as actions/checkout leaves
    it), pushing to `origin` (a local bare repository standing in for GitHub)."""
    (step,) = [s for s in RELEASE["jobs"]["major-tag"]["steps"]
               if s.get("name") == "Move the major tag"]
    _git(clone, "checkout", "-q", "--detach", tag)
    p = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", step["run"]], cwd=clone,
                       env={**os.environ, "TAG": tag, "TOKEN": "t0ken", "REMOTE": str(origin),
                            "GIT_CONFIG_GLOBAL": os.devnull, "GIT_CONFIG_NOSYSTEM": "1"},
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stdout + p.stderr
    return p.stdout


def _action_repository(tmp_path: Path) -> tuple[Path, Path]:
    """A bare `origin` holding the action's files as committed here, and a clone of it."""
    origin, clone = tmp_path / "origin.git", tmp_path / "clone"
    _git(tmp_path, "init", "-q", "--bare", str(origin))
    _git(tmp_path, "init", "-q", "-b", "main", str(clone))
    for name in ("action.yml", "constraints.txt"):
        shutil.copy2(ROOT / name, clone / name)
    _git(clone, "add", ".")
    _git(clone, "commit", "-q", "-m", "release 0.1.0")
    _git(clone, "remote", "add", "origin", str(origin))
    return origin, clone


def _tag(clone: Path, tag: str, message: str, branch: str = "main") -> str:
    _git(clone, "commit", "-q", "--allow-empty", "-m", message)
    _git(clone, "tag", "-a", tag, "-m", tag)  # annotated, as `git tag -a` releases are
    _git(clone, "push", "-q", "origin", f"HEAD:refs/heads/{branch}", f"refs/tags/{tag}")
    return _git(clone, "rev-parse", "HEAD")


def test_the_major_tag_follows_the_newest_release(tmp_path: Path) -> None:
    """On v0.1.0 the job creates v0; on v0.2.0 it moves v0 there; a fix v0.1.1 on the older
    line leaves v0 where it is; a tag that is not vX.Y.Z moves nothing."""
    origin, clone = _action_repository(tmp_path)

    def v0() -> str:
        return _git(origin, "rev-parse", "refs/tags/v0^{commit}")

    first = _tag(clone, "v0.1.0", "0.1.0")
    assert "v0 -> v0.1.0" in _move_major_tag(clone, origin, "v0.1.0") and v0() == first
    second = _tag(clone, "v0.2.0", "0.2.0")
    _move_major_tag(clone, origin, "v0.2.0")
    assert v0() == second
    _git(clone, "checkout", "-q", "--detach", "v0.1.0")
    _tag(clone, "v0.1.1", "a fix on 0.1", branch="release-0.1")
    assert "v0.2.0 is newer, v0 stays" in _move_major_tag(clone, origin, "v0.1.1")
    assert v0() == second
    _git(clone, "checkout", "-q", "--detach", "v0.2.0")
    _tag(clone, "v1.0.0rc1", "a candidate", branch="next")
    assert "not vX.Y.Z" in _move_major_tag(clone, origin, "v1.0.0rc1")
    assert "v1" not in _git(origin, "tag").split()


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A project with the two 3 s line scenarios and baselines accepted from a first run."""
    return make_project(tmp_path_factory.mktemp("project"))


@pytest.mark.long(reason="runs the action at the tag: a kartci run")
def test_the_action_runs_at_the_major_tag(project: Path, tmp_path: Path) -> None:
    """v0.1.0 tagged and v0 moved in a temporary clone; `uses: team/kartci@v0` resolved as the
    runner does (the repository fetched at the ref) and its steps run through the emulator."""
    from composite import run_action

    origin, clone = _action_repository(tmp_path)
    _tag(clone, "v0.1.0", "0.1.0")
    _move_major_tag(clone, origin, "v0.1.0")
    at_tag = tmp_path / "_actions" / "team" / "kartci" / "v0"
    _git(tmp_path, "clone", "-q", "--depth", "1", "--branch", "v0", f"file://{origin}",
         str(at_tag))
    action = yaml.safe_load((at_tag / "action.yml").read_text())
    work = tmp_path / "work"
    work.mkdir()
    bin_dir = str(Path(sys.executable).parent)
    env = {**os.environ, "PATH": os.pathsep.join([bin_dir, os.environ.get("PATH", "")]),
           "KARTCI_ROOT": str(project), "CI": "true", "GITHUB_ACTIONS": "true",
           "GITHUB_STEP_SUMMARY": str(tmp_path / "step_summary.md")}
    github = {"action_path": str(at_tag), "event_name": "push", "repository": "team/robot",
              "server_url": "https://github.com", "run_id": "7", "job": "kartci",
              "token": "t0ken"}
    ran = run_action(action, {"scenarios": "line_straight"}, github, work, env,
                     skip=lambda name: name == "Install kartci")  # offline: installed here
    assert ran.code == 0, ran.stdout[-3000:]
    assert ran.outputs["exit-code"] == "0"
    summary = json.loads((work / "reports" / "kartci" / "summary.json").read_text())
    assert sorted(summary["scenarios"]) == ["line_straight"] and summary["exit_code"] == 0
