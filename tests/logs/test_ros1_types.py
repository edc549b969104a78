"""extract writes ROS 2 types: a ROS 1 bag's tf/tfMessage and rosgraph_msgs/Log come out as
tf2_msgs/TFMessage and rcl_interfaces/Log, and read back with their values."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from kartci.logs import extract, messages


def _bag(path: Path) -> None:
    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                      "tf/msg/tfMessage"))
    t = store.types
    with Writer(path) as w:
        tf = w.add_connection("/tf", "tf/msg/tfMessage", typestore=store)
        log = w.add_connection("/rosout", "rosgraph_msgs/msg/Log", typestore=store)
        for k in range(3):
            stamp = t["builtin_interfaces/msg/Time"](sec=10 + k, nanosec=5)
            hdr = t["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id="odom")
            tr = t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=float(k), y=0.0, z=0.0),
                rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
            m = t["tf/msg/tfMessage"](transforms=[t["geometry_msgs/msg/TransformStamped"](
                header=hdr, child_frame_id="base_link", transform=tr)])
            w.write(tf, (10 + k) * 10**9, store.serialize_ros1(m, "tf/msg/tfMessage"))
            line = t["rosgraph_msgs/msg/Log"](header=hdr, level=4, name="/amcl", msg=f"w{k}",
                                             file="amcl.cpp", function="f", line=7,
                                             topics=["/tf"])
            w.write(log, (10 + k) * 10**9, store.serialize_ros1(line, "rosgraph_msgs/msg/Log"))


def test_ros1_type_names_become_their_ros2_counterparts(tmp_path: Path) -> None:
    bag = tmp_path / "old.bag"
    _bag(bag)
    out = tmp_path / "tf.mcap"
    assert extract(bag, ["/tf", "/rosout"], out) == 6
    with out.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert sorted(s.name for s in summary.schemas.values()) == [
        "rcl_interfaces/msg/Log", "tf2_msgs/msg/TFMessage"]
    got = list(messages(out))
    tfs = [m for topic, _, m in got if topic == "/tf"]
    assert [m.transforms[0].transform.translation.x for m in tfs] == [0.0, 1.0, 2.0]
    assert [m.transforms[0].header.stamp.sec for m in tfs] == [10, 11, 12]
    logs = [m for topic, _, m in got if topic == "/rosout"]
    assert [(m.stamp.sec, m.level, m.name, m.msg, m.line) for m in logs] == [
        (10 + k, 30, "/amcl", f"w{k}", 7) for k in range(3)]  # ROS 1 WARN (4) is ROS 2's 30
