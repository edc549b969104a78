"""`kartci init`: a team's repository becomes a kartci project, and kartci installed from its
wheel runs it (the issue's done-when, step by step, in a fresh venv)."""

from __future__ import annotations

import json
import subprocess
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from helpers import kartci
from venvs import offline_env

from kartci import __version__
from kartci.errors import SpecError
from kartci.project import ProjectConfig, find_project
from kartci.scaffold import (
    SCENARIO,
    WHEELS,
    Install,
    dependency_pins,
    init_project,
    install_from,
    install_source,
    workflow_text,
)

FILES = ["kartci.toml", f"scenarios/{SCENARIO}.yaml", "baselines/README.md",
         ".github/workflows/kartci.yml", "constraints.txt", "README.md", ".gitignore"]


def _tree(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): p.read_text(errors="replace")
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.long(reason="a fresh venv from the wheel")
def test_init_then_run_then_baseline_update_from_the_installed_wheel(
        fresh_venv: Path, tmp_path: Path) -> None:
    """In a new empty folder, with kartci installed from its wheel: `kartci init && kartci run`
    runs and passes, and `kartci baseline update` writes into the project's baselines/."""
    repo = tmp_path / "robot-repo"
    repo.mkdir()
    env = offline_env(fresh_venv)

    def k(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([str(fresh_venv / "kartci"), *args], cwd=repo, env=env,
                              capture_output=True, text=True, timeout=300)

    where = subprocess.run([str(fresh_venv / "python"), "-c",
                            "import kartci; print(kartci.__file__)"],
                           cwd=repo, env=env, capture_output=True, text=True, check=True)
    assert where.stdout.startswith(str(fresh_venv.parent)), where.stdout  # the wheel's kartci
    assert k("--version").stdout.strip() == f"kartci {__version__}"

    init = k("init")
    assert init.returncode == 0, init.stderr
    assert init.stderr == ""  # no warning: the gate installs the wheel this kartci came from
    wheels = list((repo / WHEELS).iterdir())
    assert [w.name for w in wheels] == [f"kartci-{__version__}-py3-none-any.whl"]
    spec = f"./{WHEELS.as_posix()}/{wheels[0].name}"
    assert f"the gate installs: {spec}" in init.stdout
    assert sorted(_tree(repo)) == sorted([*FILES, f"{WHEELS.as_posix()}/{wheels[0].name}"])
    assert (repo / ".github/workflows/kartci.yml").read_text() == workflow_text(Install(spec))
    assert f'-c constraints.txt "{spec}"' in (repo / "README.md").read_text()

    run = k("run")
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    summary = json.loads((repo / "reports/latest/summary.json").read_text())
    assert list(summary["scenarios"]) == [SCENARIO] and summary["exit_code"] == 0
    assert sorted(p.name for p in (repo / "baselines").iterdir()) == ["README.md"]

    update = k("baseline", "update", "reports/latest")
    assert update.returncode == 0, update.stderr
    stored = json.loads((repo / "baselines" / f"{SCENARIO}.json").read_text())
    assert stored["scenario"] == SCENARIO and "cross_track_rms_m" in stored["metrics"]

    again = k("run")  # now judged against the baseline just written
    assert again.returncode == 0, again.stdout[-2000:]
    summary = json.loads((repo / "reports/latest/summary.json").read_text())
    statuses = {m["status"] for m in summary["scenarios"][SCENARIO]["metrics"].values()}
    assert statuses == {"pass"}


def test_init_refuses_to_overwrite_and_force_does(tmp_path: Path) -> None:
    first = kartci("init", tmp_path)
    assert first.returncode == 0, first.stderr
    (tmp_path / "scenarios" / f"{SCENARIO}.yaml").write_text("edited: by the team\n")
    before = _tree(tmp_path)

    again = kartci("init", tmp_path)
    assert again.returncode == 2 and "Traceback" not in again.stderr
    (line,) = again.stderr.strip().splitlines()
    assert "kartci.toml already exists (and 4 more)" in line and "--force" in line
    assert _tree(tmp_path) == before  # nothing written

    forced = kartci("init", tmp_path, "--force")
    assert forced.returncode == 0, forced.stderr
    after = _tree(tmp_path)
    assert after[f"scenarios/{SCENARIO}.yaml"] != "edited: by the team\n"
    assert after["README.md"] == before["README.md"]  # the section is not added twice
    assert after[".gitignore"].count("reports/") == after[".gitignore"].count(".venv/") == 1


def test_init_adds_a_table_to_an_existing_pyproject_and_keeps_the_rest(tmp_path: Path) -> None:
    pyproject = ("[project]\nname = \"team-stack\"\nversion = \"1.2.3\"\n\n"
                 "[tool.ruff]\nline-length = 99\n")
    (tmp_path / "pyproject.toml").write_text(pyproject)
    (tmp_path / "README.md").write_text("# team-stack\n\nOur controllers.\n")
    (tmp_path / ".gitignore").write_text("*.pyc\n/reports\n")
    steps = init_project(tmp_path)
    assert {str(s.path): s.action.value for s in steps}["pyproject.toml"] == "appended to"
    assert not (tmp_path / "kartci.toml").exists()
    text = (tmp_path / "pyproject.toml").read_text()
    assert text.startswith(pyproject)
    data = tomllib.loads(text)
    assert data["project"]["name"] == "team-stack" and data["tool"]["ruff"]["line-length"] == 99
    ProjectConfig.model_validate(data["tool"]["kartci"])
    proj = find_project(tmp_path / "scenarios")  # found from a subfolder, like pytest's rootdir
    assert proj.root == tmp_path and proj.config_file == tmp_path / "pyproject.toml"
    assert [p.stem for p in proj.own_scenarios()] == [SCENARIO]
    readme = (tmp_path / "README.md").read_text()
    assert readme.startswith("# team-stack\n\nOur controllers.\n\n<!-- kartci -->")
    # reports already ignored; the venv the docs make is added
    assert (tmp_path / ".gitignore").read_text() == "*.pyc\n/reports\n\n.venv/\n"

    (tmp_path / "kartci.toml").unlink(missing_ok=True)
    refused = kartci("init", tmp_path)  # the table is there now: the team's file is never rewritten
    assert refused.returncode == 2
    assert "pyproject.toml already has [tool.kartci]" in refused.stderr


def test_a_new_kartci_toml_is_a_valid_project(tmp_path: Path) -> None:
    init_project(tmp_path / "new")  # a missing folder is created
    cfg = tomllib.loads((tmp_path / "new" / "kartci.toml").read_text())
    ProjectConfig.model_validate(cfg)
    proj = find_project(tmp_path / "new")
    assert proj.config_file == tmp_path / "new" / "kartci.toml"
    assert proj.baselines == tmp_path / "new" / "baselines"


@pytest.mark.parametrize("bad", ["file", "pyproject", "scenarios", "readme", "binary"])
def test_bad_init_targets_are_one_line_and_write_nothing(tmp_path: Path, bad: str) -> None:
    target = tmp_path / "target"
    if bad == "file":
        target.write_text("not a folder")
    else:
        target.mkdir()
        if bad == "pyproject":
            (target / "pyproject.toml").write_text("[project\nname = 1\n")
        elif bad == "scenarios":
            (target / "scenarios").write_text("a file where the folder goes")
        elif bad == "readme":
            (target / "README.md").mkdir()
        else:
            (target / "README.md").write_bytes(b"\xff\xfe\x00")
    before = sorted(p.name for p in target.iterdir()) if target.is_dir() else []
    p = kartci("init", target, "--force")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    (line,) = p.stderr.strip().splitlines()
    assert str(target) in line
    assert (sorted(p.name for p in target.iterdir()) if target.is_dir() else []) == before


def test_constraints_pin_the_installed_numeric_dependencies(tmp_path: Path) -> None:
    pins = dependency_pins()
    for name in ("numpy", "scipy", "pybullet", "casadi"):
        assert f"{name}=={metadata.version(name)}" in pins
    assert not any(p.startswith("kartci==") for p in pins)
    init_project(tmp_path)
    lines = (tmp_path / "constraints.txt").read_text().splitlines()
    assert [ln for ln in lines if not ln.startswith("#")] == pins


GIT = ('{"url": "https://github.com/team/kartci.git", "vcs_info": {"vcs": "git", '
       '"requested_revision": "v0", "commit_id": "0123456789abcdef0123456789abcdef01234567"}}')
HTTPS = ('{"url": "https://example.org/kartci-0.1.0-py3-none-any.whl", "archive_info": '
         '{"hashes": {"sha256": "ab12"}, "hash": "sha256=ab12"}}')
FOLDER = '{"url": "file:///src/kartci", "dir_info": {"editable": true}}'


@pytest.mark.parametrize(("direct_url", "requirement", "warns"), [
    (None, "kartci==0.1.0", False),  # from a package index: no direct_url.json
    (GIT, "kartci @ git+https://github.com/team/kartci.git"
          "@0123456789abcdef0123456789abcdef01234567", False),
    (HTTPS, "kartci @ https://example.org/kartci-0.1.0-py3-none-any.whl#sha256=ab12", False),
    ('{"url": "https://example.org/k.whl", "archive_info": {}}',
     "kartci @ https://example.org/k.whl", False),
    (FOLDER, "kartci==0.1.0", True),  # editable: a fallback, and a warning naming the fix
    ('{"url": "file:///gone/kartci-0.1.0-py3-none-any.whl", "archive_info": {}}',
     "kartci==0.1.0", True),
])
def test_the_gate_installs_the_kartci_that_ran_init(direct_url: str | None, requirement: str,
                                                    warns: bool) -> None:
    got = install_from(direct_url, "0.1.0")
    assert got.requirement == requirement and got.wheel is None
    assert (got.warning is not None) == warns
    if got.warning:
        assert "kartci init --force --kartci SPEC" in got.warning
        assert "KARTCI_REQUIREMENT" in got.warning and "\n" not in got.warning


def test_a_local_wheel_is_copied_into_the_project(tmp_path: Path) -> None:
    wheel = tmp_path / "dist dir" / "kartci-0.1.0-py3-none-any.whl"
    wheel.parent.mkdir()
    wheel.write_bytes(b"PK\x03\x04 not really a zip")
    got = install_from(f'{{"url": "{wheel.as_uri()}", "archive_info": {{}}}}', "0.1.0")
    assert got == Install("./.kartci/wheels/kartci-0.1.0-py3-none-any.whl", wheel=wheel)
    repo = tmp_path / "repo"
    steps = init_project(repo, install=got)
    assert (repo / WHEELS / wheel.name).read_bytes() == wheel.read_bytes()
    gate = (repo / ".github/workflows/kartci.yml").read_text()
    assert "|| './.kartci/wheels/kartci-0.1.0-py3-none-any.whl' }}" in gate
    assert {str(s.path): s.action.value for s in steps}[f".kartci/wheels/{wheel.name}"] == (
        "created")
    again = init_project(repo, force=True, install=got)  # the same bytes: kept
    assert {str(s.path): s.action.value for s in again}[f".kartci/wheels/{wheel.name}"] == "kept"
    wheel.write_bytes(b"other bytes")
    with pytest.raises(SpecError, match="already exists"):
        init_project(repo, install=got)


def test_kartci_option_sets_the_requirement_and_bad_ones_are_refused(tmp_path: Path) -> None:
    spec = "kartci @ git+https://github.com/team/kartci@v0"
    p = kartci("init", tmp_path, "--kartci", spec)
    assert p.returncode == 0 and p.stderr == "", p.stderr
    assert f"|| '{spec}' }}}}" in (tmp_path / ".github/workflows/kartci.yml").read_text()
    assert f"the gate installs: {spec}" in p.stdout
    for bad in ("kartci==1' || 'x", 'a"b', "kartci #x", "${{ secrets.X }}", "a\nb", ""):
        with pytest.raises(SpecError, match="not a pip requirement"):
            install_source(bad)
    refused = kartci("init", tmp_path / "other", "--kartci", "x'y")
    assert refused.returncode == 2 and "not a pip requirement" in refused.stderr
    assert not (tmp_path / "other").exists()


@pytest.mark.parametrize(("origin", "requirement"), [
    ("https://user:t0ken@github.com/team/kartci.git",
     "kartci @ git+https://github.com/team/kartci.git@v0.1.0"),
    ("git@github.com:team/kartci.git", "kartci @ git+https://github.com/team/kartci.git@v0.1.0"),
    ("ssh://git@example.org:2222/team/kartci", "kartci @ git+https://example.org/team/kartci@v0.1.0"),
    ("/srv/git/kartci.git", "kartci==0.1.0"),  # a path on this machine: CI cannot fetch it
    (None, "kartci==0.1.0"),  # no origin
])
def test_a_folder_install_falls_back_to_its_origins_release(
        tmp_path: Path, origin: str | None, requirement: str) -> None:
    """kartci installed from a git checkout (editable): the gate installs the release tag of
    its version from the checkout's origin, never a credential, and says so on one line."""
    checkout = tmp_path / "kartci src"
    subprocess.run(["git", "init", "-q", str(checkout)], check=True, timeout=60)
    if origin is not None:
        subprocess.run(["git", "-C", str(checkout), "remote", "add", "origin", origin],
                       check=True, timeout=60)
    got = install_from(f'{{"url": "{checkout.as_uri()}", "dir_info": {{"editable": true}}}}',
                       "0.1.0")
    assert got.requirement == requirement and got.warning is not None
    assert f"the gate installs {requirement}, " in got.warning and "t0ken" not in got.warning
    assert str(checkout) in got.warning


def test_init_from_a_folder_warns_on_one_line(tmp_path: Path) -> None:
    """The test environment's kartci is an editable install: the gate gets the fallback and
    the team is told what to set before its first pull request."""
    if install_source().warning is None:
        pytest.skip("kartci is not installed from a folder here")
    p = kartci("init", tmp_path)
    assert p.returncode == 0
    (line,) = p.stderr.strip().splitlines()
    assert line.startswith("kartci: warning: kartci runs from a folder")
    assert f"the gate installs: {install_source().requirement}" in p.stdout
