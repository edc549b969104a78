"""Fast DDS's shared memory and the run's domain, without ROS 2: zombie segments (nobody holds
their lock file) are removed and live ones kept; each run holds its own ROS_DOMAIN_ID; the ROS 2
Python is found or named as missing in one line."""

from __future__ import annotations

import fcntl
from pathlib import Path

import pytest
import yaml
from helpers import ROOT, kartci

from kartci.bridge.dds import env as ros_env
from kartci.bridge.dds.env import dds_env, profile_path
from kartci.bridge.dds.shm import FIRST_DOMAIN, Domain, clean_zombies
from kartci.errors import SpecError


def _segment(folder: Path, name: str, lock: str) -> Path:
    (folder / name).write_bytes(b"\0" * 64)
    (folder / f"{name}_{lock}").touch()
    if name.startswith("fastdds_port"):
        (folder / f"sem.{name}_mutex").touch()
    return folder / f"{name}_{lock}"


def test_zombies_go_and_live_segments_stay(tmp_path: Path) -> None:
    _segment(tmp_path, "fastdds_0123456789abcdef", "el")
    _segment(tmp_path, "fastdds_port26650", "sl")
    live = _segment(tmp_path, "fastdds_fedcba9876543210", "el")
    (tmp_path / "other.zenoh").touch()
    with live.open("rb") as held:
        fcntl.flock(held, fcntl.LOCK_SH)  # as a running Fast DDS process holds it
        removed = clean_zombies(tmp_path)
    assert sorted(removed) == sorted([
        "fastdds_0123456789abcdef", "fastdds_0123456789abcdef_el", "fastdds_port26650",
        "fastdds_port26650_sl", "sem.fastdds_port26650_mutex"])
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "fastdds_fedcba9876543210", "fastdds_fedcba9876543210_el", "other.zenoh"]


def test_each_run_holds_its_own_domain(tmp_path: Path) -> None:
    a, b = Domain(tmp_path), Domain(tmp_path)
    assert (a.id, b.id) == (FIRST_DOMAIN, FIRST_DOMAIN + 1)
    a.release()
    c = Domain(tmp_path)
    assert c.id == FIRST_DOMAIN
    b.release()
    c.release()


def test_the_child_is_told_the_shm_profile_and_domain() -> None:
    env = dds_env(117, "kart0")
    assert env["FASTDDS_DEFAULT_PROFILES_FILE"] == env["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(
        profile_path())
    assert (env["ROS_DOMAIN_ID"], env["RMW_IMPLEMENTATION"]) == ("117", "rmw_fastrtps_cpp")
    text = profile_path().read_text()  # shipped in the package: SHM only, no builtin UDP
    assert "<useBuiltinTransports>false</useBuiltinTransports>" in text
    assert "<type>SHM</type>" in text and "<type>UDP" not in text


def test_a_missing_ros2_python_is_one_line(monkeypatch: pytest.MonkeyPatch,
                                           tmp_path: Path) -> None:
    monkeypatch.setenv("KARTCI_ROS2_PYTHON", str(tmp_path / "nope" / "python"))
    with pytest.raises(SpecError, match=r"^KARTCI_ROS2_PYTHON=.*/nope/python: no such file$"):
        ros_env.find_python()
    monkeypatch.delenv("KARTCI_ROS2_PYTHON")
    monkeypatch.setenv("KARTCI_CACHE_DIR", str(tmp_path))
    with pytest.raises(SpecError, match=r"run `kartci ros2 env` \(a venv in .*ros2-kilted\)"):
        ros_env.require_python()


def test_ros2_commands_print_the_profile_and_name_a_missing_python(tmp_path: Path) -> None:
    p = kartci("ros2", "profile")
    assert (p.returncode, p.stdout) == (0, f"{profile_path()}\n")
    p = kartci("ros2", "python", env={"KARTCI_ROS2_PYTHON": str(tmp_path / "python")})
    assert (p.returncode, p.stdout) == (2, "")
    assert p.stderr == f"kartci: error: KARTCI_ROS2_PYTHON={tmp_path / 'python'}: no such file\n"


def test_zenoh_settings_with_dds_are_refused_in_one_line(tmp_path: Path) -> None:
    spec = yaml.safe_load((ROOT / "examples" / "ros2_stack" / "scenarios" /
                           "dds_pure_pursuit.yaml").read_text())
    spec["agents"]["kart0"]["controller"].update(port=7447, connect=["tcp/127.0.0.1:7447"])
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    (tmp_path / "scenarios" / "dds_port.yaml").write_text(yaml.safe_dump(spec))
    p = kartci("run", "dds_port", "--out", tmp_path / "out", cwd=tmp_path)
    assert p.returncode == 2, p.stdout + p.stderr
    assert ("agent kart0: middleware dds does not use the Zenoh settings port, connect (the "
            "stack meets kartci on its DDS domain, over shared memory)") in p.stdout + p.stderr
