"""Whose configuration kartci trusts: a project file found by walking up folders names code to
import and folders to write, so one owned by another user, or writable by others, is refused
(git's CVE-2022-24765 and safe.directory); the walk stops at a file-system boundary; with no
project at all, nothing is written outside --out."""

from __future__ import annotations

import contextlib
import os
import pwd
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import kartci

from kartci import project

PLUGIN = "import pathlib\npathlib.Path(__file__).with_name('IMPORTED').touch()\n"
ROOT_ONLY = pytest.mark.skipif(os.geteuid() != 0, reason="giving a file to another user "
                                                         "needs root")


def shared_parent(base: Path) -> tuple[Path, Path]:
    """A parent folder holding a kartci.toml with a plugin (which leaves a mark when imported),
    and an empty working folder below it."""
    parent = base / "shared"
    (parent / "work").mkdir(parents=True)
    (parent / "kartci.toml").write_text('plugins = ["planted"]\n')
    (parent / "planted.py").write_text(PLUGIN)
    return parent, parent / "work"


def isolated(base: Path, **extra: str) -> dict[str, str]:
    """No user-level configuration but the one the test writes (in base/config)."""
    return {"XDG_CONFIG_HOME": str(base / "config"), "KARTCI_SAFE_DIRECTORIES": "", **extra}


@ROOT_ONLY
def test_a_configuration_owned_by_another_user_is_refused_and_its_plugins_never_run(
        tmp_path: Path) -> None:
    parent, work = shared_parent(tmp_path)
    nobody = pwd.getpwnam("nobody")
    os.chown(parent / "kartci.toml", nobody.pw_uid, nobody.pw_gid)
    p = kartci("list", cwd=work, env=isolated(tmp_path))
    assert p.returncode == 2
    assert p.stderr == (
        f"kartci: error: {parent}/kartci.toml is owned by nobody, not by root, who runs "
        "kartci: its plugins and paths would act as you, so it is not used; if you trust "
        f"it, run with KARTCI_SAFE_DIRECTORIES={parent} or add it to safe_directories in "
        f"{tmp_path}/config/kartci/config.toml\n")
    assert not (parent / "IMPORTED").exists()
    assert not list(work.iterdir())


@ROOT_ONLY
@pytest.mark.parametrize("how", ["environment", "user config"])
def test_a_folder_the_user_lists_as_safe_is_trusted(tmp_path: Path, how: str) -> None:
    parent, work = shared_parent(tmp_path)
    nobody = pwd.getpwnam("nobody")
    os.chown(parent / "kartci.toml", nobody.pw_uid, nobody.pw_gid)
    env = isolated(tmp_path)
    if how == "environment":
        env["KARTCI_SAFE_DIRECTORIES"] = os.pathsep.join(["/elsewhere", str(parent)])
    else:
        (tmp_path / "config" / "kartci").mkdir(parents=True)
        (tmp_path / "config" / "kartci" / "config.toml").write_text(
            f'safe_directories = ["{parent}"]\n')
    p = kartci("list", cwd=work, env=env)
    assert p.returncode == 0, p.stderr
    assert (parent / "IMPORTED").exists()


def test_a_configuration_writable_by_others_is_refused(tmp_path: Path) -> None:
    parent, work = shared_parent(tmp_path)
    (parent / "kartci.toml").chmod(0o666)
    p = kartci("plugins", cwd=work, env=isolated(tmp_path))
    assert p.returncode == 2
    assert p.stderr.startswith(f"kartci: error: {parent}/kartci.toml is writable by others "
                               "(mode 0666): its plugins and paths would act as you")
    assert not (parent / "IMPORTED").exists()
    (parent / "kartci.toml").chmod(0o644)
    parent.chmod(0o777)  # anyone could replace the file
    p = kartci("plugins", cwd=work, env=isolated(tmp_path))
    assert p.returncode == 2
    assert p.stderr.startswith(f"kartci: error: {parent} (the folder of kartci.toml) is "
                               "writable by others (mode 0777)")


@contextlib.contextmanager
def mounted(folder: Path) -> Iterator[None]:
    """A fresh tmpfs at `folder` (another file system), or the test skips."""
    folder.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "kartci-test", str(folder)],
                                           capture_output=True).returncode != 0:
        pytest.skip("mounting a tmpfs needs root and a mount permission")
    try:
        yield
    finally:
        subprocess.run(["umount", str(folder)], check=True)


def test_discovery_stops_at_a_file_system_boundary(tmp_path: Path) -> None:
    (tmp_path / "kartci.toml").write_text('plugins = ["planted"]\n')
    (tmp_path / "planted.py").write_text(PLUGIN)
    with mounted(tmp_path / "mnt"):
        (tmp_path / "mnt" / "work").mkdir()
        proj = project.find_project(tmp_path / "mnt" / "work")
        assert proj.config_file is None and not proj.found
        assert proj.root == tmp_path / "mnt" / "work"
        assert project.find_project(tmp_path).config_file == tmp_path / "kartci.toml"


def test_with_no_project_a_run_says_so_and_writes_nothing(tmp_path: Path) -> None:
    """`kartci run` started where no project is (`/`, a home folder) created reports/ there
    silently; now it asks for --out, and writes only there."""
    here = tmp_path / "here"
    here.mkdir()
    p = kartci("run", "line_straight", cwd=here, env=isolated(tmp_path))
    assert p.returncode == 2
    assert p.stderr == (
        f"kartci: error: no kartci project found in {here} or a folder above it (no "
        "kartci.toml, no pyproject.toml with [tool.kartci]): pass --out DIR to say where to "
        "write, or make a project with `kartci init`\n")
    assert not list(here.iterdir())
    (here / "out").mkdir()
    p = kartci("baseline", "update", "out", cwd=here, env=isolated(tmp_path))
    assert p.returncode == 2
    assert "pass --baselines DIR (in Python: baselines=) to say where to write" in p.stderr
    assert [f.name for f in here.iterdir()] == ["out"]
