"""Fast DDS's shared memory and the run's domain: zombie segments (no lock held, no live process
mapping or holding them) are removed and live ones kept; each run holds its own ROS_DOMAIN_ID,
host-wide, and skips one a live participant is on; the ROS 2 Python is found or named as missing
in one line; the profile goes in the variable the installed Fast DDS reads. The tests with real
Fast DDS processes skip, saying why, where no ROS 2 Python can be made."""

from __future__ import annotations

import contextlib
import fcntl
import json
import mmap
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import ROOT, kartci

from bridge.dds.ros2python import ros_python_or_skip
from kartci.bridge import attach
from kartci.bridge.child import Child
from kartci.bridge.dds import env as ros_env
from kartci.bridge.dds import shm
from kartci.bridge.dds.env import dds_env, profile_path
from kartci.bridge.dds.relay import description
from kartci.bridge.dds.shm import FIRST_DOMAIN, Domain, clean_zombies, discovery_port
from kartci.core import RunFolder
from kartci.errors import RunError, SpecError
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import Session

CHATTER = Path(__file__).with_name("chatter.py")
SHM = Path("/dev/shm")
FAST = ("/dev/shm/fastdds_", "/dev/shm/sem.fastdds_")


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


def test_a_crash_survivors_orphans_go_unless_a_live_process_maps_them(tmp_path: Path) -> None:
    """A port segment and its mutex without a lock file (a survivor removed it, or it never
    had one) go once no live process maps or holds them; one this process maps stays."""
    for port in (7000, 9160, 9161):
        (tmp_path / f"fastdds_port{port}").write_bytes(b"\0" * 4096)
        (tmp_path / f"sem.fastdds_port{port}_mutex").write_bytes(b"\0" * 32)
    with (tmp_path / "fastdds_port9161").open("r+b") as f, mmap.mmap(f.fileno(), 4096):
        held = (tmp_path / "sem.fastdds_port9160_mutex").open("rb")  # an open descriptor
        try:
            removed = clean_zombies(tmp_path)
        finally:
            held.close()
        assert sorted(removed) == ["fastdds_port7000", "sem.fastdds_port7000_mutex"]
    assert sorted(clean_zombies(tmp_path)) == sorted([  # nobody uses them now
        "fastdds_port9160", "fastdds_port9161", "sem.fastdds_port9160_mutex",
        "sem.fastdds_port9161_mutex"])
    assert list(tmp_path.iterdir()) == []


def test_what_a_hidden_process_could_use_stays(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """While some process cannot be inspected (another user's), a family another user could
    write is kept: nothing proves it unused."""
    monkeypatch.setattr(shm, "in_use", lambda shm_dir: (set(), True))
    for name, mode in (("fastdds_port7000", 0o644), ("fastdds_port7001", 0o666)):
        (tmp_path / name).touch()
        (tmp_path / name).chmod(mode)
    assert clean_zombies(tmp_path) == ["fastdds_port7000"]


def test_each_run_holds_its_own_domain(tmp_path: Path) -> None:
    a, b = Domain(tmp_path, tmp_path), Domain(tmp_path, tmp_path)
    assert (a.id, b.id) == (FIRST_DOMAIN, FIRST_DOMAIN + 1)
    a.release()
    c = Domain(tmp_path, tmp_path)
    assert c.id == FIRST_DOMAIN
    b.release()
    c.release()


def test_a_domain_a_live_participant_is_on_is_not_claimed(tmp_path: Path) -> None:
    """A participant kartci did not start (no kartci lock) holds its discovery port's shared
    lock: its domain is skipped; once it is dead, the domain is free again."""
    port = tmp_path / f"fastdds_port{discovery_port(FIRST_DOMAIN)}"
    assert port.name == "fastdds_port32650"  # 7400 + 250 * 101
    port.touch()
    (tmp_path / f"{port.name}_sl").touch()
    (tmp_path / "locks").mkdir()
    with (tmp_path / f"{port.name}_sl").open("rb") as lock:
        fcntl.flock(lock, fcntl.LOCK_SH)
        d = Domain(tmp_path / "locks", tmp_path)
        assert (d.id, d.skipped) == (FIRST_DOMAIN + 1, [FIRST_DOMAIN])
        d.release()
    d = Domain(tmp_path / "locks", tmp_path)
    assert d.id == FIRST_DOMAIN
    d.release()


_HOLD = ("import sys; from kartci.bridge.dds.shm import Domain; d = Domain(); "
         "print(d.id, flush=True); sys.stdin.read()")


def test_two_runs_with_different_cache_folders_get_different_domains(tmp_path: Path) -> None:
    """The lock is the host's (beside /dev/shm), not the user's cache folder: two runs started
    at once with their own KARTCI_CACHE_DIR hold two ids (both took 101 before)."""
    procs = [subprocess.Popen([sys.executable, "-c", _HOLD], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True,
                              env={**os.environ, "KARTCI_CACHE_DIR": str(tmp_path / c)})
             for c in ("cache_a", "cache_b")]
    try:
        ids = [int(p.stdout.readline()) for p in procs if p.stdout is not None]
    finally:
        for p in procs:
            p.communicate("", timeout=30)
    assert len(ids) == 2 and ids[0] != ids[1], ids
    folder = SHM / shm.DOMAINS_FOLDER
    assert (folder.stat().st_mode & 0o7777, sorted(
        (folder / f"{i}.lock").stat().st_mode & 0o777 for i in ids)) == (0o1777, [0o444] * 2)


def _fake_python(tmp_path: Path, library: str) -> Path:
    """A 'Python' whose version probe finds `library` mapped."""
    path = tmp_path / f"python-{library}"
    path.write_text(f"#!/bin/sh\necho {library}\n")
    path.chmod(0o755)
    return path


def test_the_profile_goes_in_the_variable_the_installed_fast_dds_reads(tmp_path: Path) -> None:
    """Fast DDS 3 reads FASTDDS_ (and warns at every start while FASTRTPS_ is set: set empty),
    2.x reads FASTRTPS_ only (else UDP multicast); unknown: both."""
    profile = str(profile_path())
    v3, v2, broken = (_fake_python(tmp_path, lib) for lib in (
        "libfastdds.so.3.2", "libfastrtps.so.2.14.1", "nothing"))
    assert ros_env.fastdds_version(v3) == (3, 2)
    assert ros_env.fastdds_version(v2) == (2, 14)
    assert ros_env.fastdds_version(broken) is None
    pick = {p: {k: v for k, v in dds_env(5, "kart0", p).items() if "PROFILES" in k}
            for p in (v3, v2, broken)}
    assert pick == {
        v3: {"FASTDDS_DEFAULT_PROFILES_FILE": profile, "FASTRTPS_DEFAULT_PROFILES_FILE": ""},
        v2: {"FASTDDS_DEFAULT_PROFILES_FILE": "", "FASTRTPS_DEFAULT_PROFILES_FILE": profile},
        broken: {"FASTDDS_DEFAULT_PROFILES_FILE": profile,
                 "FASTRTPS_DEFAULT_PROFILES_FILE": profile}}


def test_an_error_tail_leads_with_the_cause_not_fast_dds_deprecation(tmp_path: Path) -> None:
    warning = ("[WARN] [1795928766.821294890] [rmw_fastrtps_shared_cpp]: "
               "FASTRTPS_DEFAULT_PROFILES_FILE value is used for participant configuration, "
               "but it is deprecated and will no longer be supported. Use "
               "FASTDDS_DEFAULT_PROFILES_FILE instead.")
    child = Child(["sh", "-c", f"echo 'RuntimeError: the real cause' >&2; echo '{warning}' >&2"],
                  tmp_path, {}, tmp_path, "stack")
    child.proc.wait(10)
    assert child.tail() == "stack.stderr.log: RuntimeError: the real cause"


def test_attaching_ros2_tools_is_one_ready_command(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """run.json's facts (domain, profile) and the command printed on a terminal, not in CI."""
    env = {**dds_env(117, "kart0"), "FASTRTPS_DEFAULT_PROFILES_FILE": ""}
    facts = attach.for_dds(env, "/kart0/cmd_vel")
    profile = profile_path()
    assert facts.command == (f"ROS_DOMAIN_ID=117 FASTDDS_DEFAULT_PROFILES_FILE={profile} "
                             "RMW_IMPLEMENTATION=rmw_fastrtps_cpp ros2 topic echo /kart0/cmd_vel")
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    monkeypatch.setenv("CI", "true")
    attach.announce(tmp_path, "kart0", facts)
    assert capsys.readouterr().err == ""
    monkeypatch.delenv("CI")
    attach.announce(tmp_path, "kart0", facts)
    assert capsys.readouterr().err == (f"kartci: kart0 on dds; attach ROS 2 tools with: "
                                       f"{facts.command}\n")
    assert RunFolder(tmp_path).read_attach() == {"kart0": {
        "middleware": "dds", "rmw": "rmw_fastrtps_cpp", "domain_id": 117,
        "profile": str(profile), "profile_variables": ["FASTDDS_DEFAULT_PROFILES_FILE"],
        "command": facts.command}}


def test_a_humble_installation_is_named_as_such(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Humble has the .msg but no REP 2011 type description (.json): the relay says it cannot
    serve Humble over DDS, not 'is std_msgs installed?'."""
    msg = tmp_path / "humble" / "share" / "rosgraph_msgs" / "msg"
    msg.mkdir(parents=True)
    (msg / "Clock.msg").write_text("builtin_interfaces/Time clock\n")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "humble"))
    with pytest.raises(RuntimeError) as err:
        description("rosgraph_msgs/msg/Clock")
    assert str(err.value) == (
        f"this ROS 2 has no type descriptions (rosgraph_msgs/msg/Clock: "
        f"share/rosgraph_msgs/msg/Clock.msg but no Clock.json under {tmp_path / 'humble'}, "
        f"{sys.prefix}); the DDS relay needs them and runtime type hashes (REP 2011: ROS 2 "
        "Iron and later), so a Humble stack cannot use middleware dds: run it over "
        "middleware zenoh (ros_distro: humble)")
    with pytest.raises(RuntimeError, match=r"\(is std_msgs installed\?\)$"):
        description("std_msgs/msg/String")


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


# ---- with real Fast DDS processes (a ROS 2 Python) ----

@pytest.fixture(scope="module")
def ros_python() -> Path:
    return ros_python_or_skip()


class _Chatter:
    """A chatter node on a domain with kartci's SHM-only profile, its output read as it comes."""

    def __init__(self, python: Path, tag: str, domain_id: int) -> None:
        self.proc = subprocess.Popen(
            [str(python), str(CHATTER), tag], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL, text=True, start_new_session=True,
            env={**os.environ, **dds_env(domain_id, "kart0", python)})
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        try:
            self.wait_for("up")
        except BaseException:  # not yet in the fixture's list: end it here, never leave it
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
            raise

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.strip())

    def wait_for(self, line: str, timeout_s: float = 30.0) -> None:
        """Until the node has printed `line` (it is up, it heard another node)."""
        deadline = time.monotonic() + timeout_s
        while line not in self.lines:
            assert time.monotonic() < deadline, f"no {line!r} within {timeout_s:g} s"
            assert self.proc.poll() is None or self._reader.is_alive(), self.lines
            time.sleep(0.02)

    def heard(self) -> list[str]:
        """Every tag it received, once told to end."""
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        self.proc.wait(30)
        self._reader.join(5)
        got = [line for line in self.lines if line.startswith("got ")]
        return list(json.loads(got[0].split(" ", 1)[1]))


@pytest.fixture
def chatters(dds_alone: None) -> Iterator[list[_Chatter]]:
    """The test's nodes (killed if still there at its end); one DDS test at a time, as the
    others compare /dev/shm before and after."""
    nodes: list[_Chatter] = []
    yield nodes
    for n in nodes:
        if n.proc.poll() is None:
            os.killpg(n.proc.pid, signal.SIGKILL)
            n.proc.wait()


def test_no_message_crosses_between_two_runs_domains(ros_python: Path, tmp_path: Path,
                                                     chatters: list[_Chatter]) -> None:
    """A foreign participant on 101 (no kartci lock): two runs' domains skip it and differ;
    three nodes on one topic, each on its own domain, hear only themselves."""
    chatters.append(_Chatter(ros_python, "foreign", FIRST_DOMAIN))
    deadline = time.monotonic() + 10
    while not shm.occupied(FIRST_DOMAIN) and time.monotonic() < deadline:
        time.sleep(0.05)
    a, b = Domain(tmp_path), Domain(tmp_path)  # own lock folder: only the participant check
    try:
        assert FIRST_DOMAIN not in (a.id, b.id) and a.id != b.id
        chatters += [_Chatter(ros_python, "a", a.id), _Chatter(ros_python, "b", b.id)]
        time.sleep(2.0)  # discovery (shared memory) and some 40 messages each
        assert [n.heard() for n in chatters] == [["foreign"], ["a"], ["b"]]
    finally:
        a.release()
        b.release()


def _shm_files(pid: int) -> set[tuple[int, int]]:
    """(device, inode) of every Fast DDS file in /dev/shm process `pid` maps or holds open."""
    mine = set()
    for line in Path(f"/proc/{pid}/maps").read_text().splitlines():
        cols = line.split(maxsplit=5)
        if len(cols) == 6 and cols[5].startswith(FAST):
            mine.add((_device(cols[3]), int(cols[4])))
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        if str(fd.readlink()).startswith(FAST):
            st = fd.stat()
            mine.add((st.st_dev, st.st_ino))
    return mine


def _family(name: str) -> str:
    """A Fast DDS file's family: its segment's name."""
    return name.removeprefix("sem.").removesuffix("_mutex").removesuffix("_el").removesuffix(
        "_sl")


def _families_of(*pids: int) -> set[str]:
    """The families of every Fast DDS file the processes map or hold open (their own segments
    and ports, and the ports of others they send to)."""
    names = set()
    for pid in pids:
        for line in Path(f"/proc/{pid}/maps").read_text().splitlines():
            cols = line.split(maxsplit=5)
            if len(cols) == 6 and cols[5].startswith(FAST):
                names.add(Path(cols[5]).name)
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            with contextlib.suppress(OSError):
                if str(fd.readlink()).startswith(FAST):
                    names.add(fd.readlink().name)
    return {_family(n) for n in names}


def _left_of(families: set[str]) -> list[str]:
    """Files of `families` still in /dev/shm that no live process keeps."""
    return _kept([p for p in SHM.iterdir() if _family(p.name) in families])


def _device(text: str) -> int:
    major, minor = text.split(":")
    return os.makedev(int(major, 16), int(minor, 16))


def _kept_keys() -> set[tuple[int, int]]:
    """(device, inode) of every Fast DDS file a live process keeps: an flock on it
    (/proc/locks), a mapping or an open descriptor (every /proc/<pid> this user can read)."""
    keys = set()
    for line in Path("/proc/locks").read_text().splitlines():
        cols = line.split()
        if len(cols) > 5 and cols[1] == "FLOCK":
            device, _, inode = cols[5].rpartition(":")
            keys.add((_device(device), int(inode)))
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            for line in (proc / "maps").read_text().splitlines():
                cols = line.split(maxsplit=5)
                if len(cols) == 6 and cols[5].startswith(FAST):
                    keys.add((_device(cols[3]), int(cols[4])))
            for fd in (proc / "fd").iterdir():
                if str(fd.readlink()).startswith(FAST):
                    keys.add((fd.stat().st_dev, fd.stat().st_ino))
        except OSError:
            continue
    return keys


def _kept(files: list[Path]) -> list[str]:
    """Those of `files` whose family (a segment, its `_el`/`_sl` lock file, its
    `sem.<segment>_mutex`) no live process keeps (see `_kept_keys`)."""
    keys = _kept_keys()

    def kept(base: str) -> bool:
        for name in (base, f"{base}_el", f"{base}_sl", f"sem.{base}_mutex"):
            with contextlib.suppress(OSError):
                st = (SHM / name).stat()
                if (st.st_dev, st.st_ino) in keys:
                    return True
        return False

    return [p.name for p in files if p.exists() and not kept(_family(p.name))]


def _dead_after_cleaning(t0: float) -> list[str]:
    """Fast DDS files changed since `t0` whose family no live process keeps, after cleaning.
    /dev/shm is the host's: another job's killed process may leave a zombie at any moment, so
    a leftover counts only if a second and third cleaning leave it too."""
    dead: list[str] = []
    for _ in range(3):
        clean_zombies()
        with contextlib.suppress(FileNotFoundError):
            recent = [p for p in SHM.iterdir() if p.name.startswith(
                ("fastdds_", "sem.fastdds_")) and p.stat().st_mtime >= t0]
            dead = _kept(recent)
            if not dead:
                break
        time.sleep(0.2)
    return dead


@pytest.mark.skipif(not SHM.is_dir(), reason="no /dev/shm on this system")
def test_a_killed_stack_leaves_nothing_in_shared_memory(ros_python: Path,
                                                        chatters: list[_Chatter]) -> None:
    """kill -9 of one node of a two-node stack; the other talks on, then ends cleanly (it
    leaves the dead node's port segments and mutexes, without lock files). After the
    cleaning no Fast DDS file of this test's time is left that no live process keeps, and
    none of the killed node's files is there at all."""
    t0 = time.time() - 1.0
    domain = Domain()
    try:
        victim = _Chatter(ros_python, "victim", domain.id)
        survivor = _Chatter(ros_python, "survivor", domain.id)
        chatters += [victim, survivor]
        victim.wait_for("heard survivor")  # they discovered each other and talk
        survivor.wait_for("heard victim")
        victims = _shm_files(victim.proc.pid)
        assert len(victims) >= 4, "the node maps its segment and ports"
        families = _families_of(victim.proc.pid, survivor.proc.pid)
        os.killpg(victim.proc.pid, signal.SIGKILL)
        victim.proc.wait()
        time.sleep(0.5)
        assert survivor.heard() == ["survivor", "victim"]
    finally:
        domain.release()
    assert _dead_after_cleaning(t0) == []
    assert _left_of(families) == []
    left = {(p.stat().st_dev, p.stat().st_ino) for p in SHM.iterdir()}
    assert victims & left == set()


@pytest.mark.skipif(not SHM.is_dir(), reason="no /dev/shm on this system")
def test_a_run_whose_stack_is_killed_leaves_nothing_of_it(ros_python: Path, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch,
                                                          dds_alone: None) -> None:
    """kill -9 of the example stack mid-run (the relay lives on, as the issue's crash): the
    run ends in an error and, once closed, nothing is left of what the stack and the relay
    used (their segments, ports, lock files, mutexes) unless a live process keeps it, and
    none of the stack's files is there at all."""
    proj = tmp_path / "ros2_stack"
    shutil.copytree(ROOT / "examples" / "ros2_stack", proj,
                    ignore=shutil.ignore_patterns("reports"))
    monkeypatch.chdir(proj)
    monkeypatch.setenv("KARTCI_ROS2_PYTHON", str(ros_python))
    spec = load_scenario("dds_pure_pursuit", ["duration_s=2.0"], project=active_project())
    with Session(spec, proj / "run.mcap") as s:
        s.reset()
        for _ in range(5):
            s.step()
        agent: Any = s.world.robots[0].agent
        stack = _shm_files(agent.child.proc.pid)
        assert len(stack) >= 4, "the stack maps its segment and ports"
        families = _families_of(agent.child.proc.pid, agent.relay.proc.pid)
        os.killpg(agent.child.proc.pid, signal.SIGKILL)
        agent.child.proc.wait()
        with pytest.raises(RunError, match="external controller of kart0: the program exited"):
            for _ in range(50):
                s.step()
    assert _left_of(families) == []  # the run's end cleaned what its processes used
    left = {(p.stat().st_dev, p.stat().st_ino) for p in SHM.iterdir()}
    assert stack & left == set()


@pytest.mark.long(reason="two DDS runs of the example stack at once")
def test_two_kartci_runs_at_once_with_own_cache_folders_stay_apart(
        ros_python: Path, tmp_path: Path, dds_alone: None) -> None:
    """Two `kartci run`s started together, each with its own KARTCI_CACHE_DIR: two domains in
    their run.json, every tick answered in both, and equal metrics (a stack hearing the other
    run's odometry as well drives otherwise: 944 odometry messages for 501 ticks before)."""
    proj = tmp_path / "ros2_stack"
    shutil.copytree(ROOT / "examples" / "ros2_stack", proj,
                    ignore=shutil.ignore_patterns("reports"))
    procs = [subprocess.Popen(
        [sys.executable, "-m", "kartci.cli", "run", "dds_pure_pursuit", "--set",
         "duration_s=4", "--out", str(tmp_path / f"out_{c}"), "--no-strict"], cwd=proj,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "KARTCI_CACHE_DIR": str(tmp_path / f"cache_{c}"),
             "KARTCI_ROS2_PYTHON": str(ros_python)}) for c in "ab"]
    for p in procs:
        out, _ = p.communicate(timeout=240)
        assert p.returncode == 1, out  # 4 s: no lap, the criterion fails; the run does not
    folders = [tmp_path / f"out_{c}" / "dds_pure_pursuit" for c in "ab"]
    domains = [json.loads((f / "run.json").read_text())["attach"]["kart0"]["domain_id"]
               for f in folders]
    assert domains[0] != domains[1]
    for f in folders:
        timing = json.loads((f / "kart0.dds_round_trip.log").read_text())
        assert (timing["ticks"], timing["late_commands"]) == (200, 0)
    a, b = (json.loads((f / "metrics.json").read_text())["metrics"] for f in folders)
    assert a == b
