"""`controller: {type: external, middleware: dds}`: the same lockstep as over Zenoh (`/clock`
and the sensors out, the commands back, a late answer counted), served on Fast DDS by a relay
process that runs under a ROS 2 Python (`relay.py`), so kartci itself never imports rclpy.

kartci and the relay talk over a Unix socket in a private folder: one ordered, reliable byte
stream both ways with no network; either side's death is an end-of-file the other sees at once
(the relay then exits, kartci names its last output). Shared memory would save a few
microseconds a tick (a round trip through the stack costs about a millisecond) at the price of
its own signalling; a pipe pair would take the relay's stdout, which is its log.

Every DDS process kartci starts (the relay, and the stack when kartci starts it) gets kartci's
shared-memory-only Fast DDS profile and the run's own ROS_DOMAIN_ID in its environment before
rclpy starts: no UDP socket, so nothing leaves the host, and `-j N` runs do not meet.
"""

from __future__ import annotations

import contextlib
import json
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from kartci.atomic import write_text_atomic
from kartci.bridge import ros2
from kartci.bridge.agent import CLOCK, ExternalAgent, substitute
from kartci.bridge.attach import announce, for_dds
from kartci.bridge.child import Child
from kartci.bridge.dds import env as ros_env
from kartci.bridge.dds import relay as wire
from kartci.bridge.dds.env import dds_env
from kartci.bridge.dds.shm import Domain, clean_zombies
from kartci.bridge.lockstep import Durability, Endpoint, Kind, Phase, Qos, Reliability
from kartci.bridge.params import ExternalController
from kartci.core import AgentContext
from kartci.errors import RunError, SpecError
from kartci.logs.types import msg

# <agent>.<this> in the run folder (kept there with the programs' logs): one JSON line of
# wall-clock figures, so not in the deterministic metrics
ROUND_TRIP = "dds_round_trip.log"
ZENOH_ONLY = {"port": None, "connect": (), "zenoh_mode": "peer", "allow_remote": False}
CONNECT_TIMEOUT_S = 20.0  # s, for the relay to start its Python and connect
# starts of the stack when its first tick gets no answer: the links between the stack's own
# nodes are invisible to kartci, and under load a quiet graph was seen to start t = 0 before
# two nodes had matched (a first message lost, then every tick late: 1 run in 10 on CI)
START_ATTEMPTS = 3


class DdsAgent(ExternalAgent):
    """The bridge for one agent over DDS: the relay process, the stack's process, the lockstep
    (inherited: `step`, the deadline, late ticks, decoding and applying the commands)."""

    def __init__(self, spec: ExternalController, ctx: AgentContext) -> None:
        zenoh_only = [k for k, default in ZENOH_ONLY.items() if getattr(spec, k) != default]
        if zenoh_only:
            raise SpecError(f"agent {ctx.name}: middleware dds does not use the Zenoh "
                            f"settings {', '.join(zenoh_only)} (the stack meets kartci on its "
                            "DDS domain, over shared memory)")
        self._lockstep_state(spec, ctx)  # ExternalAgent's, without its Zenoh session
        self.relay: Child | None = None
        self._missing_now = ["an answer from the DDS relay"]
        self._relay_ready = threading.Event()
        self._publishing = threading.Event()
        self._graph: list[Endpoint] = []
        self._relay_error: str | None = None
        self._lock = threading.Lock()
        self.round_trips_s: list[float] = []
        self.starts = 0  # of the stack, by kartci
        self.python = ros_env.require_python()
        self._folder = Path(tempfile.mkdtemp(prefix="kartci-dds-"))  # the relay's socket
        clean_zombies()  # what killed runs before this one left
        self.domain = Domain() if spec.command else None
        self.domain_id = self.domain.id if self.domain else spec.domain_id
        self.endpoint = f"DDS domain {self.domain_id} (shared memory)"
        try:
            announce(ctx.run_dir, self.name, for_dds(  # run.json + terminal
                dds_env(self.domain_id, self.name, self.python), [*self.commands, "/clock"][0]))
            self.sock = self._start_relay(ctx.run_dir)
            self._reader = threading.Thread(target=self._read, daemon=True)
            self._reader.start()
        except BaseException:
            self.close()
            raise

    def _start_relay(self, run_dir: Path | None) -> socket.socket:
        """Start the relay, accept its connection, tell it the node, /clock and the commands."""
        path = self._folder / "relay.sock"
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as server:
            server.bind(str(path))
            server.listen(1)
            server.settimeout(0.1)
            self.relay = Child(
                [str(self.python), str(Path(wire.__file__)), "--socket", str(path)],
                self._folder, dds_env(self.domain_id, self.name, self.python),
                run_dir or self._folder,
                f"{self.name}.dds_relay")
            deadline = time.perf_counter() + CONNECT_TIMEOUT_S
            while True:
                try:
                    sock, _ = server.accept()
                    break
                except TimeoutError:
                    self._relay_alive()
                    if time.perf_counter() > deadline:
                        raise RunError(f"external controller of {self.name}: the DDS relay "
                                       f"({self.python}) did not connect within "
                                       f"{CONNECT_TIMEOUT_S:g} s; {self._relay_output()}"
                                       ) from None
        sock.settimeout(None)
        return sock

    def _send_start(self) -> None:
        """Tell the relay the node, its publishers (/clock and the first tick's topics, made
        now so that the graph settles with them matched) and the commands."""
        distro = self.spec.ros_distro
        publishers = {("/clock", CLOCK)} | {(t, type(m).__msgtype__) for t, m in self._pending}
        wire.send(self.sock, self._lock, {
            "op": "start", "node": self.spec.node_name,
            "publishers": [[t, ty, ros2.type_hash(ty, distro)] for t, ty in sorted(publishers)],
            "commands": [[t, ty, ros2.type_hash(ty, distro)] for t, ty in self.commands.items()],
            "observe": [self._full(w.topic) for w in self.spec.waits_for if w.count],
            "optional": sorted(self._optional()),
            "settle_s": self.spec.graph_settle_s})

    def _read(self) -> None:
        """The relay's frames, on a thread of their own: commands into the inbox."""
        while (frame := wire.receive(self.sock)) is not None:
            head, body = frame
            if head["op"] == "cmd":
                self.inbox.push(head["topic"], body)
            elif head["op"] == "seen":
                self.inbox.push(head["topic"], None)
            elif head["op"] == "publishing":
                self._publishing.set()
            elif head["op"] == "missing":
                self._missing_now = list(head["what"])
            elif head["op"] == "ready":
                self._graph = [Endpoint(node, Kind(kind), topic, typename,
                                        Qos(Reliability(rel), Durability(dur), depth))
                               for node, kind, topic, typename, rel, dur, depth in head["graph"]]
                self._relay_ready.set()
            elif head["op"] == "error":
                self._relay_error = str(head["message"])
        self._relay_error = self._relay_error or "it closed its connection"

    def _start(self, run_dir: Path | None) -> Child:
        root = self.root
        values = {"python": sys.executable, "ros_python": str(self.python),
                  "endpoint": self.endpoint, "root": str(root),
                  "domain_id": str(self.domain_id), "namespace": self.name}
        argv = [substitute(a, values) for a in self.spec.command]
        cwd = root / self.spec.cwd if self.spec.cwd else root
        env = {**dds_env(self.domain_id, self.name, self.python),
               **{k: substitute(v, values) for k, v in self.spec.env.items()}}
        return Child(argv, cwd, env, run_dir or self._folder, f"{self.name}.external")

    def _relay_alive(self) -> None:
        code = self.relay.exited() if self.relay is not None else None
        if self._relay_error is not None or code is not None:
            raise RunError(f"external controller of {self.name}: the DDS relay failed ("
                           f"{self._relay_error or f'exit code {code}'}); "
                           f"{self._relay_output()}")

    def _relay_output(self) -> str:
        return f"relay {self.relay.tail()}" if self.relay is not None else "no relay"

    def _check_alive(self, t_ns: int) -> None:
        super()._check_alive(t_ns)
        self._relay_alive()

    def step(self, t_ns: int) -> Any:
        """The lockstep tick, timed (wall clock: sensors and /clock out, every answer back)
        from the second tick on (the first waits for the stack to start)."""
        ready, t0 = self._ready, time.perf_counter()
        out = super().step(t_ns)
        if ready:
            self.round_trips_s.append(time.perf_counter() - t0)
        return out

    def timing(self) -> dict[str, float]:
        """Round trips per tick (median, p99, max, ms), their count, the late ticks."""
        ticks = sorted(self.round_trips_s)
        if not ticks:
            return {"ticks": 0, "late_commands": self.late}

        def at(q: float) -> float:
            return round(ticks[min(len(ticks) - 1, int(q * len(ticks)))] * 1e3, 3)
        return {"ticks": len(ticks), "median_ms": at(0.5), "p99_ms": at(0.99),
                "max_ms": at(1.0), "late_commands": self.late, "starts": self.starts}

    def _wait_ready(self) -> None:
        """The relay's publishers first, then the stack (its nodes find kartci's publishers in
        their first discovery: a publisher made after a best-effort subscription was seen to
        miss tick 0 when the subscription's side matched it late), then until the relay sees
        the stack's /clock subscription and command publishers, matched, and the graph settled;
        then plan the ticks from the graph the relay saw."""
        deadline = time.perf_counter() + self.spec.startup_timeout_s
        if not self.starts:
            self._send_start()
            while not self._publishing.wait(0.01):
                self._check_alive(0)
                if time.perf_counter() > deadline:
                    raise RunError(f"external controller of {self.name}: the DDS relay made no "
                                   f"publishers within {self.spec.startup_timeout_s:g} s; "
                                   f"{self._relay_output()}")
        if self.spec.command:
            self.child = self._start(self.run_dir)
            self.starts += 1
        while not self._relay_ready.wait(0.01):
            self._check_alive(0)
            if time.perf_counter() > deadline:
                raise RunError(f"external controller of {self.name}: within "
                               f"{self.spec.startup_timeout_s:g} s the stack declared no "
                               f"{', no '.join(self._missing_now)} on {self.endpoint}; "
                               f"{self._output()}")
        if self.starts > 1:
            self.inbox.take()  # what the stack stopped before sent
        self._plan(self._graph)
        self._ready = True

    def _restartable(self) -> bool:
        """A stack kartci started, not yet started START_ATTEMPTS times."""
        return self.child is not None and self.starts < START_ATTEMPTS

    def _restart(self, first: list[tuple[str, Any]]) -> None:
        """The first tick got no answer: stop the stack (its logs kept as
        `<agent>.external.start<k>.*.log`), forget tick 0, have the relay wait for the new
        stack's graph to settle for twice as long as before, and make tick 0 again with the
        same sensor messages. Nothing of the stopped stack reaches the run: sim time has not
        moved, and a stack that answers its first tick starts as it always does."""
        assert self.child is not None and self.ledger is not None
        missing = self.ledger.missing(Phase.SENSORS) + self.ledger.missing(Phase.CLOCK)
        settle_s = self.spec.graph_settle_s * 2 ** self.starts
        print(f"{self.name}: no answer to the first tick within {self.spec.tick_timeout_s:g} s"
              f" (waiting for {', '.join(missing) or 'nothing'}): its nodes may not have "
              f"found each other yet; starting the stack again (start {self.starts + 1} of "
              f"{START_ATTEMPTS}, graph settling {settle_s:g} s)", file=sys.stderr)
        self.child.stop(self.spec.stop_timeout_s)
        for log in (self.child.stdout_path, self.child.stderr_path):
            with contextlib.suppress(OSError):
                log.rename(log.with_name(log.name.replace(
                    ".external.", f".external.start{self.starts}.")))
        self.child, self.ledger, self._ready = None, None, False
        self._arrived, self._latest, self._got = [], {}, {}
        self._pending = list(first)
        self._relay_ready.clear()
        wire.send(self.sock, self._lock, {"op": "restart", "settle_s": settle_s})

    def _publish_sensors(self, t_ns: int) -> None:
        """The tick's sensor messages, one frame to the relay, published in order."""
        self._send(t_ns)

    def _publish_clock(self, t_ns: int) -> None:
        """The tick's /clock, a frame of its own (after the sensors' answers came)."""
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        self._pending.append(("/clock", msg(CLOCK, clock=msg(
            "builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec))))
        self._send(t_ns)

    def _send(self, t_ns: int) -> None:
        distro = self.spec.ros_distro
        heads, bodies = [], []
        for topic, m in self._pending:
            typename = type(m).__msgtype__
            data = ros2.serialize(m, distro)
            heads.append([topic, typename, ros2.type_hash(typename, distro), len(data)])
            bodies.append(data)
        self._pending.clear()
        try:
            wire.send(self.sock, self._lock, {"op": "tick", "t_ns": t_ns, "msgs": heads},
                      b"".join(bodies))
        except OSError as err:
            self._relay_alive()
            raise RunError(f"external controller of {self.name}: the DDS relay is gone "
                           f"({err}); {self._relay_output()}") from err

    def close(self) -> None:
        """Stop the stack, end the relay (its socket closed: rclpy shuts down), release the
        domain and remove the shared memory the run's processes left (idempotent)."""
        self._write_arrivals()
        if self.child is not None:
            self.child.stop(self.spec.stop_timeout_s)
        sock: socket.socket | None = getattr(self, "sock", None)
        if sock is not None:
            with contextlib.suppress(OSError):  # already shut by the relay's end
                sock.shutdown(socket.SHUT_RDWR)  # wakes the reader thread's recv
            sock.close()
        if self.relay is not None:
            deadline = time.perf_counter() + self.spec.stop_timeout_s
            while self.relay.exited() is None and time.perf_counter() < deadline:
                time.sleep(0.01)
            self.relay.stop(self.spec.stop_timeout_s)
        if self.domain is not None:
            self.domain.release()
        if self.run_dir is not None and self.round_trips_s:
            write_text_atomic(self.run_dir / f"{self.name}.{ROUND_TRIP}",
                              json.dumps(self.timing(), sort_keys=True) + "\n")
        clean_zombies()
        (self._folder / "relay.sock").unlink(missing_ok=True)
        if self._folder.exists() and not any(self._folder.iterdir()):
            self._folder.rmdir()


