"""Fixed-layout CDR (kartci/logs/cdr.py) writes rosbags' bytes, and declines what differs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader

from kartci.logs import header, msg, typestore
from kartci.logs.cdr import compile_fixed
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import simulate
from kartci.sim.messages import joint_state


@pytest.mark.parametrize("scenario", ["line_circle", "kart_manual"])
def test_every_logged_message_serialises_to_rosbags_bytes(tmp_path: Path,
                                                          scenario: str) -> None:
    """Each message of a run's log, decoded and serialised again by the layouts its topic
    gets (up to four, as the writer keeps): rosbags' bytes, or a decline."""
    simulate(load_scenario(scenario, ["duration_s=1"],
                           project=active_project()), tmp_path / "run.mcap")
    store, layouts, fitted, total = typestore(), dict[str, list[Any]](), 0, 0
    with (tmp_path / "run.mcap").open("rb") as f:
        for schema, channel, record in make_reader(f).iter_messages():
            assert schema is not None
            m = store.deserialize_cdr(record.data, schema.name)
            own = layouts.setdefault(channel.topic, [])
            out = next((b for lay in own if (b := lay(m)) is not None), None)
            if out is None and len(own) < 4 and (made := compile_fixed(store, m)) is not None:
                own.append(made)
                out = made(m)
            total += 1
            if out is not None:
                fitted += 1
                assert out == record.data, channel.topic
    assert fitted > 0.95 * total


def test_a_message_laid_out_otherwise_is_declined() -> None:
    store = typestore()
    first = joint_state(10, "lt0/base_link", ["l", "r"], [], [1.0, 2.0])
    layout = compile_fixed(store, first)
    assert layout is not None
    assert layout(joint_state(20, "lt0/base_link", ["l", "r"], [], [3.0, -4.5])) == bytes(
        store.serialize_cdr(joint_state(20, "lt0/base_link", ["l", "r"], [], [3.0, -4.5]),
                            "sensor_msgs/msg/JointState"))
    assert layout(joint_state(20, "lt1/base_link", ["l", "r"], [], [3.0, 4.0])) is None
    assert layout(joint_state(20, "lt0/base_link", ["l", "r", "c"], [], [3.0, 4.0, 5.0])) is None
    assert layout(joint_state(20, "lt0/base_link", ["l", "r"], [0.1, 0.2], [3.0, 4.0])) is None
    sensor = msg("kartci_msgs/msg/LineSensor", header=header(0, "lt0/line_sensor"), left=0.5,
                 right=0.25)
    assert layout(sensor) is None  # another type
    odd = joint_state(20, "lt0/base_link", ["l", "r"], [], [3.0, 4.0])
    odd.velocity = np.array([3.0, 4.0], dtype=np.float32)  # half the bytes: no fit
    assert layout(odd) is None
