"""An unmodified rclpy node (examples/ros2_stack: Odometry in, Twist out, use_sim_time) drives
the kart over Fast DDS from `kartci run`, in lockstep, and scores its committed baseline; the
DDS processes open no UDP socket (shared memory only) and leave no shared memory behind, also
when killed. Skipped, saying why, where no ROS 2 Python can be made."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import ROOT, kartci

from bridge.dds.ros2python import ros_python_or_skip
from bridge.dds.test_shm import _families_of, _left_of
from kartci.bridge.dds.env import dds_env
from kartci.bridge.dds.shm import clean_zombies
from kartci.errors import RunError
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import Session

EXAMPLE = ROOT / "examples" / "ros2_stack"
SHM = Path("/dev/shm")


@pytest.fixture(scope="module")
def ros_python() -> Path:
    return ros_python_or_skip()


@pytest.fixture
def example(tmp_path: Path, ros_python: Path, monkeypatch: pytest.MonkeyPatch,
            dds_alone: None) -> Path:
    """A copy of the example project, the current folder, with the ROS 2 Python named."""
    proj = tmp_path / "ros2_stack"
    shutil.copytree(EXAMPLE, proj, ignore=shutil.ignore_patterns("reports"))
    monkeypatch.chdir(proj)
    monkeypatch.setenv("KARTCI_ROS2_PYTHON", str(ros_python))
    return proj


def fastdds_files() -> set[str]:
    return {p.name for p in SHM.glob("*fastdds_*")} if SHM.is_dir() else set()


@pytest.mark.long(reason="a ROS 2 node over DDS for a full run")
def test_rclpy_node_drives_the_kart_in_lockstep_and_scores_its_baseline(
        example: Path, record_property: Any) -> None:
    before = fastdds_files()
    out = example / "out"
    p = kartci("run", "dds_pure_pursuit", "--out", out, cwd=example)
    assert p.returncode == 0, p.stdout + p.stderr
    summary = json.loads((out / "summary.json").read_text())["scenarios"]["dds_pure_pursuit"]
    assert {c: v["ok"] for c, v in summary["criteria"].items()} == {
        "collisions": True, "laps_completed": True}
    assert {m: v["status"] for m, v in summary["metrics"].items()} == dict.fromkeys(
        json.loads((example / "baselines" / "dds_pure_pursuit.json").read_text())["metrics"],
        "pass")
    timing = json.loads((out / "dds_pure_pursuit" / "kart0.dds_round_trip.log").read_text())
    late = json.loads((out / "dds_pure_pursuit" / "metrics.json").read_text())["timing"]
    assert late["late_commands"]["value"] == timing["late_commands"] == 0
    assert timing["ticks"] == 1750  # 35 s at 0.02 s, the first (start-up) tick not timed
    for key in ("median_ms", "p99_ms", "late_commands"):
        record_property(f"dds_round_trip_{key}", timing[key])
    print(f"DDS round trip per tick: median {timing['median_ms']} ms, p99 {timing['p99_ms']} "
          f"ms, max {timing['max_ms']} ms, {timing['late_commands']} late of "
          f"{timing['ticks']}")
    assert fastdds_files() <= before


def _socket_inodes(pid: int) -> set[str]:
    out = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            link = str(fd.readlink())
        except OSError:
            continue
        if link.startswith("socket:["):
            out.add(link[8:-1])
    return out


def udp_sockets(pid: int) -> list[str]:
    """Local addresses (hex, as in /proc/net/udp) of the UDP sockets process `pid` holds."""
    mine = _socket_inodes(pid)
    found = []
    for table in ("udp", "udp6"):
        for line in Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]:
            cols = line.split()
            if cols[9] in mine:
                found.append(f"{table} {cols[1]}")
    return found


def test_the_udp_check_sees_a_udp_socket() -> None:
    """The check below is not blind: a process with a loopback UDP socket is seen."""
    code = ("import socket,sys,time; s=socket.socket(socket.AF_INET,socket.SOCK_DGRAM); "
            "s.bind(('127.0.0.1',0)); print(flush=True); time.sleep(30)")
    with subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE) as proc:
        assert proc.stdout is not None
        proc.stdout.readline()
        try:
            assert [s.split(":")[0] for s in udp_sockets(proc.pid)] == ["udp 0100007F"]
        finally:
            proc.kill()


def _group(pgid: int) -> list[int]:
    """Every process of a process group (the relay's or the stack's, with any children)."""
    pids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid:
            pids.append(int(stat.parent.name))
    return pids


@pytest.fixture
def session(example: Path) -> Iterator[Session]:
    spec = load_scenario("dds_pure_pursuit", ["duration_s=2.0"], project=active_project())
    with Session(spec, example / "run.mcap") as s:
        yield s


def test_dds_processes_open_no_udp_socket(session: Session) -> None:
    r = session.reset()
    for _ in range(20):
        r = session.step()
    agent: Any = session.world.robots[0].agent
    pids = _group(agent.relay.proc.pid) + _group(agent.child.proc.pid)
    assert len(pids) >= 2
    assert {pid: udp_sockets(pid) for pid in pids} == {pid: [] for pid in pids}
    assert all(_socket_inodes(pid) for pid in pids)  # they have sockets: Unix ones
    assert not r.done


def test_killed_dds_processes_leave_no_shared_memory(session: Session) -> None:
    before = fastdds_files()
    session.reset()
    for _ in range(5):
        session.step()
    agent: Any = session.world.robots[0].agent
    assert fastdds_files() - before, "the run's processes use shared memory"
    for child in (agent.child, agent.relay):
        os.killpg(child.proc.pid, signal.SIGKILL)
        child.proc.wait()
    with pytest.raises(RunError, match="external controller of kart0: the"):
        for _ in range(50):
            session.step()
    session.close()
    assert fastdds_files() <= before


def test_a_stack_started_by_hand_meets_kartci_on_its_domain(example: Path,
                                                            ros_python: Path) -> None:
    """No `command`: the team starts its node with the README's exports, kartci joins the
    scenario's `domain_id` (outside the per-run ids)."""
    env = {**os.environ, **dds_env(97, "kart0")}
    node = subprocess.Popen(
        [str(ros_python), "pure_pursuit_node.py", "--ros-args", "-r", "__ns:=/kart0", "-r",
         "track:=/kartci/track", "-p", "use_sim_time:=true"], cwd=example, env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        spec = load_scenario("dds_pure_pursuit", [
            "duration_s=1.0", "agents.kart0.controller.command=[]",
            "agents.kart0.controller.domain_id=97"], project=active_project())
        with Session(spec, example / "run.mcap") as s:
            r = s.reset()
            while not r.done:
                r = s.step()
            agent: Any = s.world.robots[0].agent
            assert (agent.child, agent.domain_id) == (None, 97)
            assert agent.timing()["ticks"] == 50 and agent.late == 0
    finally:
        node.send_signal(signal.SIGINT)  # rclpy's handler: a clean shutdown
        node.wait(10)


def test_paced_mode_runs_on_the_latest_command(example: Path) -> None:
    """`mode: paced` over DDS: sim time held to real_time_factor, the latest answer applied,
    no tick waited for (so none is late)."""
    spec = load_scenario("dds_pure_pursuit", [
        "duration_s=1.0", "agents.kart0.controller.mode=paced",
        "agents.kart0.controller.real_time_factor=2.0"], project=active_project())
    with Session(spec, example / "run.mcap") as s:
        r = s.reset()
        while not r.done:
            r = s.step()
        agent: Any = s.world.robots[0].agent
        assert agent.late == 0
        assert set(agent._latest) == {"/kart0/cmd_vel"}
        assert agent._latest["/kart0/cmd_vel"].linear.x > 0.0


def _children(pid: int) -> list[int]:
    """Every descendant of `pid`."""
    parents: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(stat.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue
        parents.setdefault(ppid, []).append(int(stat.parent.name))
    out, todo = [], [pid]
    while todo:
        kids = parents.get(todo.pop(), [])
        out += kids
        todo += kids
    return out


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    """Running (not gone, not a zombie waiting for a container's init to reap it)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_a_killed_kartci_leaves_no_dds_process_nor_shared_memory(example: Path) -> None:
    """SIGKILL to kartci mid-run: the relay and the stack see it (parent-death signal, the
    socket's end) and shut down through rclpy; what they used in /dev/shm is gone once the
    next run starts (its cleaning), judged by the files' families and liveness, not by a
    listing taken before (another job's DDS processes may come and go meanwhile)."""
    top = subprocess.Popen([sys.executable, "-m", "kartci.cli", "run", "dds_pure_pursuit",
                            "--out", str(example / "out")], cwd=example,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        dds: list[int] = []
        families: set[str] = set()
        for _ in range(600):  # until the stack answers (its node runs), at most 60 s
            dds = [p for p in _children(top.pid) if "relay.py" in _cmdline(p)
                   or "pure_pursuit_node.py" in _cmdline(p)]
            if len(dds) == 2 and (example / "out").exists():
                with contextlib.suppress(OSError):
                    families = _families_of(*dds)
                if len(families) >= 2:
                    break
            time.sleep(0.1)
        assert len(dds) == 2 and families
        kartci_pids = [top.pid] + [p for p in _children(top.pid) if p not in dds
                                   and "kartci" in _cmdline(p)]
        for pid in kartci_pids:
            os.kill(pid, signal.SIGKILL)
        top.wait()
        # both shut down through rclpy; on a loaded 2-core machine (the rest of the suite on
        # the other worker) that has taken longer than 10 s: wait up to 60 s for it to happen
        for _ in range(1200):
            if not any(map(_alive, dds)):
                break
            time.sleep(0.05)
        assert [p for p in dds if _alive(p)] == []
        clean_zombies()  # what the next run does first
        assert _left_of(families) == []
    finally:
        top.kill()
