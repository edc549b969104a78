"""The stack's program (`kartci.bridge.child.Child`): stopping it ends its whole process group,
a node started in the background of a shell included, even when it ignores SIGTERM or outlives
the program kartci started (an rclpy node was seen spinning at full CPU long after its run)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from kartci.bridge.child import Child, _group_running


def _started(tmp_path: Path, script: str) -> Child:
    child = Child(["sh", "-c", script], tmp_path, {}, tmp_path, "stack")
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:  # the background node is up once it wrote its pid
        if (tmp_path / "node.pid").exists() and (tmp_path / "node.pid").read_text().strip():
            return child
        time.sleep(0.01)
    raise AssertionError("the background node never started")


@pytest.mark.parametrize("leader", ["exec sleep 60", "exit 0"])
def test_stop_ends_a_background_node_that_ignores_sigterm(tmp_path: Path, leader: str) -> None:
    """`sh -c "node & exec program"` with SIGTERM ignored by both (an ignored signal stays
    ignored across exec), and with the program gone before the stop: nothing of the group is
    left after `stop`, within its SIGTERM wait and the SIGKILL after it."""
    child = _started(tmp_path, f"trap '' TERM; sleep 60 & echo $! > node.pid; {leader}")
    node = int((tmp_path / "node.pid").read_text())
    t0 = time.monotonic()
    child.stop(0.3)
    assert time.monotonic() - t0 < 3.0
    assert not _group_running(child.proc.pid) and not _alive(node)


def _alive(pid: int) -> bool:
    """Running, not a zombie."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def test_a_group_that_ends_on_sigterm_is_not_waited_for(tmp_path: Path) -> None:
    child = _started(tmp_path, "sleep 60 & echo $! > node.pid; exec sleep 60")
    t0 = time.monotonic()
    child.stop(5.0)
    assert time.monotonic() - t0 < 1.0 and not _group_running(child.proc.pid)
