"""kartci's local Ray instance listens and talks on loopback only (the project's network rule):
every TCP and UDP socket of every Ray process (the GCS, raylet, agents, workers and this
driver), read from /proc/net while Ray runs. No allow-list: in Ray 2.60 each of them binds to
127.0.0.1 once the node's address is 127.0.0.1 (docs/howto/ray.md)."""

from __future__ import annotations

import ipaddress
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import pytest
from helpers import PAIR, QUICK

from kartci.runner.ray_executor import start

LISTEN = "0A"  # /proc/net/tcp state codes (include/net/tcp_states.h)


class Sock(NamedTuple):
    """One socket of a Ray process, as /proc/net shows it."""

    process: str
    proto: str
    local: str
    remote: str
    state: str


def _endpoint(field: str) -> str:
    """/proc/net's hex `address:port` (the address in host-order 32-bit words) as `ip:port`,
    an IPv4-mapped IPv6 address as IPv4."""
    hex_address, hex_port = field.split(":")
    raw = bytes.fromhex(hex_address)
    ip = ipaddress.ip_address(b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4)))
    mapped = ip.ipv4_mapped if isinstance(ip, ipaddress.IPv6Address) else None
    return f"{mapped or ip}:{int(hex_port, 16)}"


def _is_loopback(endpoint: str) -> bool:
    """Loopback, or no peer (0.0.0.0:0 or [::]:0, a listening or unconnected socket)."""
    host, port = endpoint.rsplit(":", 1)
    ip = ipaddress.ip_address(host)
    return ip.is_loopback or (ip.is_unspecified and port == "0")


def _descendants(root: int) -> dict[int, str]:
    """`root` and every process below it, by pid, with its name."""
    parent: dict[int, int] = {}
    name: dict[int, str] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:  # gone since the listing
            continue
        head, _, tail = text.rpartition(")")
        pid = int(stat.parent.name)
        name[pid], parent[pid] = head.split("(", 1)[1], int(tail.split()[1])
    found = {root}
    while grown := {p for p, pp in parent.items() if pp in found} - found:
        found |= grown
    return {p: name.get(p, "?") for p in found}


def _link(fd: Path) -> str:
    try:
        return str(fd.readlink())
    except OSError:  # closed since the listing
        return ""


def _inodes(pids: dict[int, str]) -> dict[str, str]:
    """Socket inode -> the name of the process that holds it."""
    held: dict[str, str] = {}
    for pid, name in pids.items():
        try:
            links = [_link(fd) for fd in Path(f"/proc/{pid}/fd").iterdir()]
        except OSError:  # exited since the listing
            continue
        held |= {link[8:-1]: name for link in links if link.startswith("socket:[")}
    return held


def _sockets(held: dict[str, str]) -> Iterator[Sock]:
    for proto in ("tcp", "tcp6", "udp", "udp6"):
        for line in Path(f"/proc/net/{proto}").read_text().splitlines()[1:]:
            f = line.split()
            if f[9] in held:
                yield Sock(held[f[9]], proto, _endpoint(f[1]), _endpoint(f[2]), f[3])


pytestmark = pytest.mark.long(reason="starts Ray instances, one of two nodes")


@pytest.fixture(scope="module")
def ray_sockets() -> Iterator[tuple[Any, list[Sock]]]:
    """kartci's local Ray, after tasks (one with a runtime environment, through the agent) ran."""
    ray = pytest.importorskip("ray", reason='Ray is not installed (pip install "kartci[ray]")')
    start(ray, None, 1)
    try:
        task = ray.remote(num_cpus=1)(lambda: os.getpid())  # by value: workers import no tests
        env_task = task.options(runtime_env={"env_vars": {"KARTCI_PROBE": "1"}})
        ray.get([task.remote(), env_task.remote()])
        yield ray, list(_sockets(_inodes(_descendants(os.getpid()))))
    finally:
        ray.shutdown()


def test_every_ray_socket_is_on_loopback(ray_sockets: tuple[Any, list[Sock]]) -> None:
    _, socks = ray_sockets
    listening = {s.process for s in socks if s.state == LISTEN}
    assert {"gcs_server", "raylet", "ray::RuntimeEnv"} <= listening  # the probe sees Ray
    assert [s for s in socks if not (_is_loopback(s.local) and _is_loopback(s.remote))] == []


def test_ray_advertises_loopback(ray_sockets: tuple[Any, list[Sock]]) -> None:
    ray, _ = ray_sockets
    assert ray.util.get_node_ip_address() == "127.0.0.1"
    assert ray.get_runtime_context().gcs_address.startswith("127.0.0.1:")
    assert {n["NodeManagerAddress"] for n in ray.nodes()} == {"127.0.0.1"}


def test_ray_is_left_as_found() -> None:
    """Single-machine mode is Ray's own again once the instance started."""
    constants = pytest.importorskip("ray._private.ray_constants")
    assert constants.ENABLE_RAY_CLUSTER is True


def test_kartci_joins_a_two_node_cluster_on_loopback(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """Ray's own test cluster (two nodes, `ray.cluster_utils`) in Ray's single-machine mode, and
    `kartci run --ray-address` with RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 (else Ray rewrites
    127.0.0.1 to the machine's address and finds no GCS there): the scenarios run as tasks on the
    cluster and every socket, the kartci driver's included, stays on loopback."""
    ray = pytest.importorskip("ray", reason='Ray is not installed (pip install "kartci[ray]")')
    from ray.cluster_utils import Cluster  # optional dependency: ray
    monkeypatch.setattr(ray._private.ray_constants, "ENABLE_RAY_CLUSTER", False)
    cluster: Any = Cluster(initialize_head=True, head_node_args={"num_cpus": 1,
                                                            "include_dashboard": False})
    try:
        cluster.add_node(num_cpus=1)
        env = {**os.environ, "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}
        err = (tmp_path / "stderr").open("w")  # a file, not a pipe nobody reads while it runs
        run = subprocess.Popen(
            [sys.executable, "-m", "kartci.cli", "run", *PAIR, *QUICK, "--executor", "ray",
             "--ray-address", cluster.address, "--out", str(tmp_path / "out"),
             "--baselines", str(tmp_path)],  # none: judged NEW
            env=env, stdout=subprocess.DEVNULL, stderr=err)
        socks: set[Sock] = set()
        while run.poll() is None:  # the driver's sockets exist only while it runs
            socks |= set(_sockets(_inodes(_descendants(os.getpid()))))
            time.sleep(0.2)
        err.close()
        assert run.returncode == 0, (tmp_path / "stderr").read_text()
        assert sorted(p.parent.name for p in (tmp_path / "out").glob("*/metrics.json")) == sorted(
            PAIR)
        assert [n.node_ip_address for n in cluster.list_all_nodes()] == ["127.0.0.1"] * 2
        assert {s.process for s in socks if s.state == LISTEN} >= {"gcs_server", "raylet"}
        assert [s for s in socks if not (_is_loopback(s.local) and _is_loopback(s.remote))] == []
    finally:
        cluster.shutdown()
