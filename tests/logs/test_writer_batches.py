"""The log writer's batches: messages held and appended to the chunk together make the same
file, byte for byte, as mcap's own `add_message` one at a time; a run's log reads back the
same messages either way."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.writer import Writer

from kartci.logs import McapLogWriter, header, messages, msg, writer
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import simulate


def _one_at_a_time(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every record through mcap's public `add_message`, as before the batches."""
    real = writer._Chunks.__init__

    def init(self: writer._Chunks, w: Writer) -> None:
        real(self, w)
        self.builder = self.stats = None

    monkeypatch.setattr(writer._Chunks, "__init__", init)


def _write(path: Path, count: int) -> None:
    with McapLogWriter(path) as log:
        for k in range(count):
            t = k * 1_000_000
            log.write("/a", msg("kartci_msgs/msg/LineSensor", header=header(t, "lt0/line_sensor"),
                                left=0.1 * k, right=0.5), t)
            if k % 3 == 0:  # a second channel, opened half way through a batch
                log.write("/b" if k < count // 2 else "/c",
                          msg("std_msgs/msg/String", data="x" * (k % 5000)), t)


@pytest.mark.parametrize("count", [1, writer.BATCH + 7, 3 * writer.BATCH])
def test_batched_records_make_the_same_file_as_add_message(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, count: int) -> None:
    # the long strings overflow 1 MiB chunks, so a chunk is closed inside a batch
    _write(tmp_path / "batched.mcap", count)
    with monkeypatch.context() as m:
        _one_at_a_time(m)
        _write(tmp_path / "single.mcap", count)
    assert (tmp_path / "batched.mcap").read_bytes() == (tmp_path / "single.mcap").read_bytes()


def _plain(value: Any) -> Any:
    """A decoded message as nested tuples of its fields (arrays as lists), to compare."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if hasattr(value, "__dataclass_fields__"):
        return (type(value).__name__, *(_plain(getattr(value, f))
                                        for f in value.__dataclass_fields__))
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def test_a_runs_log_reads_back_the_same_messages(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    spec = load_scenario("line_circle", ["duration_s=3"], project=active_project())
    simulate(spec, tmp_path / "batched.mcap")
    with monkeypatch.context() as m:
        _one_at_a_time(m)
        simulate(spec, tmp_path / "single.mcap")
    batched = [_plain(m) for m in messages(tmp_path / "batched.mcap")]
    assert len(batched) > 1000
    assert batched == [_plain(m) for m in messages(tmp_path / "single.mcap")]
    assert (tmp_path / "batched.mcap").read_bytes() == (tmp_path / "single.mcap").read_bytes()
