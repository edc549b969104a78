"""tables() decodes the topics a run logs in volume in bulk (kartci.logs.bulk): its tables are
the ones tables_of makes message by message through rosbags, column for column, dtype for dtype,
bit for bit, on real run logs, on the real fixtures, and on logs with foreign definitions and
odd messages, which go message by message."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from mcap.writer import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from kartci.logs import open_log
from kartci.logs.bulk import standard
from kartci.logs.tables import _read, bulk_types, flatteners, tables_of
from kartci.logs.types import header, msg, typestore
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import simulate

TABLES = sys.modules["kartci.logs.tables"]
SCENARIOS = ["mpcc_lap", "multi_agent", "line_circle", "localization_lap",
             "perception_obstacles"]


def _slow(path: Path) -> dict[str, pd.DataFrame]:
    """The tables message by message, as tables() made them before bulk decoding."""
    with open_log(path) as log:
        wanted = [t.topic for t in log.topics() if t.msgtype in flatteners()]
        return tables_of(path, log.messages(wanted))


def _assert_same(fast: dict[str, pd.DataFrame], slow: dict[str, pd.DataFrame]) -> None:
    assert list(fast) == list(slow)
    for topic, want in slow.items():
        got = fast[topic]
        pd.testing.assert_frame_equal(got, want, check_exact=True, check_dtype=True,
                                      check_column_type=True, check_index_type=True)
        for col in want:  # bits too: assert_frame_equal takes -0.0 for 0.0
            a, b = got[col].to_numpy(), want[col].to_numpy()
            if a.dtype.kind in "biuf":
                assert a.tobytes() == b.tobytes(), (topic, col)
            else:
                assert [repr(x) for x in a] == [repr(x) for x in b], (topic, col)


@pytest.fixture
def bulk_results(monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, bool]]:
    """msgtype -> whether its last topic was decoded in bulk (bulk_table gave a table)."""
    found: dict[str, bool] = {}
    real = TABLES.bulk_table

    def spy(store: Any, msgtype: str, *args: Any) -> Any:
        table = real(store, msgtype, *args)
        found[msgtype] = table is not None
        return table

    monkeypatch.setattr(TABLES, "bulk_table", spy)
    yield found


@pytest.fixture(scope="module")
def run_logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("runs")
    logs = {}
    for name in SCENARIOS:
        logs[name] = root / f"{name}.mcap"
        simulate(load_scenario(name, ["duration_s=3"], project=active_project()), logs[name])
    return logs


@pytest.mark.parametrize("name", SCENARIOS)
def test_run_log_tables_equal_those_read_message_by_message(
        run_logs: dict[str, Path], name: str, bulk_results: dict[str, bool]) -> None:
    path = run_logs[name]
    _assert_same(_read(path, None), _slow(path))
    bulk = bulk_types(flatteners())
    with open_log(path) as log:
        volume = {t.msgtype for t in log.topics() if t.msgtype in bulk and t.count >= 16}
    assert volume and all(bulk_results[t] for t in volume), bulk_results  # none fell back
    some = sorted(_slow(path))[:3]
    _assert_same(_read(path, some), {t: _slow(path)[t] for t in _slow(path) if t in some})


@pytest.mark.parametrize("name", ["jackal_imu_odom.bag", "cmd_vel_twiststamped.mcap",
                                  "rosbag2_talker_mcap", "turtlebot3_gazebo_cmd_odom_scan.bag",
                                  "luminar_points_stage.bag"])
def test_real_fixtures_tables_equal_those_read_message_by_message(bags: Path, name: str) -> None:
    """Foreign logs (ROS 1 bags go message by message, a ROS 2 talker's strings too)."""
    _assert_same(_read(bags / name, None), _slow(bags / name))


def _mcap(path: Path, topics: dict[str, tuple[str, str, list[bytes]]]) -> None:
    """An MCAP of raw CDR messages: topic -> (msgtype, definition text, messages), the topics'
    messages interleaved, 10 ms apart."""
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="test")
        ids = {}
        for topic, (msgtype, text, _) in topics.items():
            sid = w.register_schema(msgtype, "ros2msg", text.encode())
            ids[topic] = w.register_channel(topic, "cdr", sid)
        for k in range(max(len(m) for _, _, m in topics.values())):
            for topic, (_, _, messages) in topics.items():
                if k < len(messages):
                    t = 10**9 + k * 10**7
                    w.add_message(ids[topic], log_time=t, publish_time=t, data=messages[k])
        w.finish()  # type: ignore[no-untyped-call]


def _cdr(m: Any, little_endian: bool = True) -> bytes:
    return bytes(typestore().serialize_cdr(m, m.__msgtype__, little_endian=little_endian))


def _definition(msgtype: str) -> str:
    return str(typestore().generate_msgdef(msgtype, ros_version=2)[0])


def _imu(k: int) -> Any:
    vec, cov = typestore().types["geometry_msgs/msg/Vector3"], np.zeros(9)
    return msg("sensor_msgs/msg/Imu", header=header(k * 10**7, "imu_link"),
               orientation=msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0),
               orientation_covariance=cov, angular_velocity=vec(0.0, 0.0, float(k)),
               angular_velocity_covariance=cov, linear_acceleration=vec(0.1 * k, -0.0, 9.81),
               linear_acceleration_covariance=cov)


def _stats(k: int) -> Any:
    return msg("kartci_msgs/msg/SolverStats", header=header(k * 10**7, "map"), success=k % 3 > 0,
               status="solved" if k % 3 else "max_iter", solve_ms=0.5 * k, iterations=k,
               cost=-1.5 * k, failures=k // 3, max_slack_m=0.0)


def _joints(k: int) -> Any:
    names = ["a", "b"] if k < 20 else ["a", "c", "d"]  # a joint set that changes
    return msg("sensor_msgs/msg/JointState", header=header(k * 10**7, ""), name=names,
               position=np.arange(len(names), dtype=float) * k, velocity=np.ones(len(names)),
               effort=np.zeros(0))


def test_odd_messages_and_layouts(tmp_path: Path, bulk_results: dict[str, bool]) -> None:
    """A big-endian message, one with bytes past its end and joint sets that change send their
    topics message by message (the undecodable one skipped, with the same note); statuses that
    change make layouts of their own, still decoded in bulk."""
    imu = [_cdr(_imu(k)) for k in range(40)]
    imu[7] = _cdr(_imu(7), little_endian=False)
    imu[9] = imu[9] + bytes(8)  # rosbags allows 3 bytes past the end, not 8
    path = tmp_path / "odd.mcap"
    _mcap(path, {
        "/imu": ("sensor_msgs/msg/Imu", _definition("sensor_msgs/msg/Imu"), imu),
        "/stats": ("kartci_msgs/msg/SolverStats", _definition("kartci_msgs/msg/SolverStats"),
                   [_cdr(_stats(k)) for k in range(40)]),
        "/joints": ("sensor_msgs/msg/JointState", _definition("sensor_msgs/msg/JointState"),
                    [_cdr(_joints(k)) for k in range(40)])})
    with warnings.catch_warnings(record=True) as fast_notes:
        warnings.simplefilter("always")
        fast = _read(path, None)
    with warnings.catch_warnings(record=True) as slow_notes:
        warnings.simplefilter("always")
        slow = _slow(path)
    _assert_same(fast, slow)
    assert [str(w.message) for w in fast_notes] == [str(w.message) for w in slow_notes]
    assert "1 on /imu" in str(fast_notes[0].message)
    assert len(fast["/imu"]) == 39 and fast["/joints"]["c.position"].isna().sum() == 20
    assert bulk_results == {"sensor_msgs/msg/Imu": False, "kartci_msgs/msg/SolverStats": True,
                            "sensor_msgs/msg/JointState": False}


def test_a_foreign_definition_is_read_by_its_own_definition(tmp_path: Path,
                                                             bulk_results: dict[str, bool]
                                                             ) -> None:
    """A log that defines kartci_msgs/LineSensor with float32 fields (another robot's package
    of the same name) is decoded by that definition, message by message."""
    text = "std_msgs/Header header\nfloat32 left\nfloat32 right\n"
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(text, "kartci_msgs/msg/LineSensor"))
    cls = store.types["kartci_msgs/msg/LineSensor"]
    hdr = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    sensor = [bytes(store.serialize_cdr(cls(hdr(stamp(0, k), "ls"), 0.1 * k, 0.3),
                                        "kartci_msgs/msg/LineSensor")) for k in range(40)]
    path = tmp_path / "foreign.mcap"
    _mcap(path, {"/ls": ("kartci_msgs/msg/LineSensor", text, sensor),
                 "/imu": ("sensor_msgs/msg/Imu", _definition("sensor_msgs/msg/Imu"),
                          [_cdr(_imu(k)) for k in range(40)])})
    with open_log(path) as log:
        assert not standard(log.typestore, "kartci_msgs/msg/LineSensor")
        assert standard(log.typestore, "sensor_msgs/msg/Imu")
    fast = _read(path, None)
    _assert_same(fast, _slow(path))
    assert fast["/ls"]["left"].tolist()[1] == float(np.float32(0.1))
    assert bulk_results == {"sensor_msgs/msg/Imu": True}
