"""The DDS tests' fixture: one DDS test at a time on this machine."""

from __future__ import annotations

import fcntl
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest


@pytest.fixture
def dds_alone(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """One DDS test at a time on this machine, across xdist workers and test runs: the tests
    that check a run leaves no Fast DDS shared memory compare /dev/shm before and after, which
    another worker's or another run's DDS processes would fill meanwhile (each run has its own
    domain, but /dev/shm is the machine's; two checkouts tested at once on one host failed so)."""
    with (Path(tempfile.gettempdir()) / "kartci-dds-tests.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield
