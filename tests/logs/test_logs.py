"""Round trips through real files: kartci's writer, rosbags' and mcap's readers, real bags."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from kartci.errors import LogError
from kartci.logs import (
    McapLogWriter,
    SalvagedLog,
    header,
    messages,
    msg,
    tables,
    topics,
    typestore,
)
from kartci.project import current as active_project


def _write_sample(path: Path) -> None:
    with McapLogWriter(path) as log:
        for k in range(5):
            t = k * 10_000_000
            log.write("/lt0/line_sensor", msg("kartci_msgs/msg/LineSensor",
                                              header=header(t, "lt0/line_sensor"),
                                              left=0.1 * k, right=0.5), t)
            log.write("/lt0/sonar", msg("sensor_msgs/msg/Range", header=header(t, "lt0/sonar"),
                                        radiation_type=0, field_of_view=0.5, min_range=0.02,
                                        max_range=4.0, range=1.0 + k), t)


def test_mcap_round_trip_through_rosbags_and_mcap(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write_sample(path)
    assert not (tmp_path / "run.mcap.partial").exists()
    with AnyReader([path], default_typestore=typestore()) as reader:
        got = [(c.topic, t, reader.deserialize(raw, c.msgtype))
               for c, t, raw in reader.messages()]
    assert len(got) == 10
    sensor = [m for topic, _, m in got if topic == "/lt0/line_sensor"]
    assert [m.left for m in sensor] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])  # type: ignore[attr-defined]
    with path.open("rb") as f:
        reader2 = make_reader(f)
        summary = reader2.get_summary()
        assert summary is not None
        assert {s.name for s in summary.schemas.values()} == {"kartci_msgs/msg/LineSensor",
                                                              "sensor_msgs/msg/Range"}
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert summary.statistics is not None and summary.statistics.message_count == 10
    df = tables(path)["/lt0/sonar"]
    assert df["range"].tolist() == pytest.approx([1.0, 2.0, 3.0, 4.0, 5.0])
    assert df["t"].tolist() == pytest.approx([0.0, 0.01, 0.02, 0.03, 0.04])


def test_tables_read_once_are_copies_and_a_rewritten_log_is_read_again(tmp_path: Path) -> None:
    """Scoring, judging and drawing a run each read its log; the second read comes from memory
    (a subset for named topics), as copies a caller may change, and a log replaced by rename
    (a new file) is decoded afresh."""
    path = tmp_path / "run.mcap"
    _write_sample(path)
    first = tables(path)
    first["/lt0/sonar"]["range"] *= 100  # a caller changing its copy
    assert tables(path)["/lt0/sonar"]["range"].tolist() == pytest.approx([1, 2, 3, 4, 5])
    assert list(tables(path, ["/lt0/line_sensor"])) == ["/lt0/line_sensor"]
    other = tmp_path / "other.mcap"
    with McapLogWriter(other) as log:
        log.write("/lt0/sonar", msg("sensor_msgs/msg/Range", header=header(0, "lt0/sonar"),
                                    radiation_type=0, field_of_view=0.5, min_range=0.02,
                                    max_range=4.0, range=9.0), 0)
    other.replace(path)
    assert tables(path)["/lt0/sonar"]["range"].tolist() == [9.0]


def test_failed_write_leaves_no_log(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with pytest.raises(RuntimeError), McapLogWriter(path):
        raise RuntimeError("controller crashed")
    assert not path.exists()
    assert not (tmp_path / "run.mcap.partial").exists()


def test_truncated_mcap_is_one_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write_sample(path)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    # the cut takes the summary; the chunk before it is salvaged, and a one-line note says so
    with pytest.warns(SalvagedLog, match=r"cut\.mcap: .*read by streaming"):
        sonar = tables(cut)["/lt0/sonar"]
    assert sonar["range"].tolist() == pytest.approx([1.0, 2.0, 3.0, 4.0, 5.0])


def test_missing_log(tmp_path: Path) -> None:
    with pytest.raises(LogError, match="no such file"):
        topics(tmp_path / "nope.bag")


def test_real_ros1_bag_imu_and_odometry(bags: Path) -> None:
    t = tables(bags / "jackal_imu_odom.bag", ["/jackal_velocity_controller/odom"])
    odom = t["/jackal_velocity_controller/odom"]
    assert len(odom) == 3060
    dt = np.diff(odom["t"].to_numpy())
    assert np.median(dt) == pytest.approx(0.02, rel=0.05)  # a 50 Hz controller, real jitter
    assert dt.min() >= 0


def test_real_bare_mcap_twist_stamped(bags: Path) -> None:
    info = {i.topic: i for i in topics(bags / "cmd_vel_twiststamped.mcap")}
    assert info["/vehicle/cmd_vel"].msgtype == "geometry_msgs/msg/TwistStamped"
    assert info["/vehicle/cmd_vel"].count == 51


def test_real_rosbag2_mcap_directory(bags: Path) -> None:
    info = {i.topic: i for i in topics(bags / "rosbag2_talker_mcap")}
    assert any(i.msgtype == "std_msgs/msg/String" for i in info.values())
    assert any(i.count == 0 for i in info.values())


def test_ros1_bag_without_messages(bags: Path) -> None:
    assert all(i.count == 0 for i in topics(bags / "ros1_no_messages.bag"))


def test_types_defined_only_inside_the_bag(bags: Path) -> None:
    """test_msgs is in no standard type store; the rosbag2 sqlite file carries the definitions."""
    got = [(topic, m) for topic, _, m in messages(bags / "rosbag2_cdr_test_db3")]
    assert {topic for topic, _ in got} == {"/array_topic", "/test_topic"}
    assert [m.__msgtype__ for t, m in got if t == "/test_topic"] == ["test_msgs/msg/BasicTypes"] * 3


def test_unknown_message_type_is_one_clear_error(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "unknown.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        sid = w.register_schema("foo_msgs/msg/Bar", "ros2msg", b"foo_msgs/Baz inner")
        cid = w.register_channel("/foo", "cdr", sid)
        w.add_message(cid, log_time=0, data=b"\x00\x01\x00\x00\x05", publish_time=0)
        w.finish()  # type: ignore[no-untyped-call]
    with pytest.raises(LogError, match=r"unknown\.mcap: "):
        list(messages(path))


def test_run_log_decodes_with_mcap_ros2_too(tmp_path: Path) -> None:
    """A second, independent decoder (mcap_ros2) reads every topic of a real run log."""
    from mcap_ros2.decoder import DecoderFactory

    from kartci.scenario import load_scenario
    from kartci.sim import simulate

    log = tmp_path / "run.mcap"
    simulate(load_scenario("line_straight", ["duration_s=1"], project=active_project()), log)
    counts: dict[str, int] = {}
    with log.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/lt0/odom":
                assert decoded.child_frame_id == "lt0/base_link"
    assert counts["/lt0/odom"] == 51  # 50 Hz over 1 s, both ends included
    assert counts["/lt0/line_sensor"] == counts["/lt0/wheel_cmd"] == 17  # ts 0.06 s
    assert {"/tf", "/tf_static", "/lt0/sonar", "/lt0/joint_states", "/lt0/controller/state",
            "/kartci/scenario", "/kartci/course"} <= set(counts)
