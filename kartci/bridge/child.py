"""The external program of a run: started with the run, watched, stopped with it; its output
goes to files in the run folder, and its last lines into any error about it."""

from __future__ import annotations

import ctypes
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

from kartci.errors import SpecError

TAIL_LINES = 8
# lines that are never an error's cause, kept out of its tail: Fast DDS 3's RMW warns at every
# start while the deprecated FASTRTPS_DEFAULT_PROFILES_FILE is set (kartci sets it empty for
# Fast DDS 3, a team's own environment may not)
NOISE = re.compile(r"FASTRTPS_DEFAULT_PROFILES_FILE value is used .* deprecated")
_PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    """In the child before exec (Linux): SIGTERM when kartci's process dies, even by SIGKILL,
    so a killed run leaves no stack behind."""
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


class Child:
    """A started program; `stop()` ends it (and its process group)."""

    def __init__(self, argv: Sequence[str], cwd: Path, env: Mapping[str, str],
                 out_dir: Path, stem: str) -> None:
        out_dir.mkdir(parents=True, exist_ok=True)
        self.stdout_path = out_dir / f"{stem}.stdout.log"
        self.stderr_path = out_dir / f"{stem}.stderr.log"
        self.argv = list(argv)
        with self.stdout_path.open("wb") as out, self.stderr_path.open("wb") as err:
            try:
                self.proc = subprocess.Popen(self.argv, cwd=cwd, env={**os.environ, **env},
                                             stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                             start_new_session=True,
                                             preexec_fn=_die_with_parent)
            except OSError as e:
                raise SpecError(f"external controller: cannot start {self.argv[0]!r} "
                                f"({e.strerror or e})") from e

    def exited(self) -> int | None:
        """Its exit code once it has ended, else None."""
        return self.proc.poll()

    def tail(self) -> str:
        """Its last lines of stderr and stdout, for an error message."""
        parts = []
        for path in (self.stderr_path, self.stdout_path):
            try:
                lines = [line for line in path.read_text(
                    encoding="utf-8", errors="replace").splitlines() if not NOISE.search(line)]
            except OSError:
                continue
            if lines:
                parts.append(f"{path.name}: " + " | ".join(lines[-TAIL_LINES:]))
        return "; ".join(parts) or "no output"

    def stop(self, timeout_s: float) -> None:
        """SIGTERM to its process group, SIGKILL after `timeout_s`; returns when no process
        of the group is left. The whole group, not the program alone: a stack started as
        `sh -c "node_a & exec node_b"` has node_a in it, and node_a may outlive node_b (an
        rclpy node was seen spinning at full CPU after SIGTERM, long after its run)."""
        for sig, wait_s in ((signal.SIGTERM, timeout_s), (signal.SIGKILL, 5.0)):
            try:
                os.killpg(self.proc.pid, sig)
            except ProcessLookupError:
                return  # no process of the group is left
            deadline = time.monotonic() + wait_s
            while time.monotonic() < deadline:
                self.proc.poll()  # reap the program itself; init reaps the rest
                if not _group_running(self.proc.pid):
                    return
                time.sleep(0.02)


def _group_running(pgid: int) -> bool:
    """Whether a process of group `pgid` is still running (a zombie is not: it only waits to
    be reaped, by a PID 1 that may never do it in a container). Linux: from /proc; elsewhere,
    whether the group can still be signalled."""
    proc = Path("/proc")
    if not proc.is_dir():
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return False
        return True
    for stat in proc.glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue  # gone meanwhile
        if int(fields[2]) == pgid and fields[0] not in ("Z", "X"):
            return True
    return False
