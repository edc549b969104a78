"""rmw_zenoh's wire conventions as kartci writes them, against values published by ROS 2 and
the examples in ros2/rmw_zenoh docs/design.md (commit 99a6a2bd10b949052f4f12c5854825dc005e95a5)."""

from __future__ import annotations

import shutil
import struct
import subprocess
from typing import Any

import pytest

from kartci.bridge import ros2
from kartci.logs.types import header, msg, typestore

# RIHS01 hashes (REP 2011) as ROS 2 publishes them. Where each expected value comes from:
PUBLISHED = {
    # ros2/rmw_zenoh docs/design.md, the `chatter` key expression example
    "std_msgs/msg/String":
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
    # `ros2 topic info -v /cmd_vel` ("Topic type hash:") output of a ROS 2 install, quoted in
    # public notes; the same value in several rmw_zenoh-compatible implementations' tables
    "geometry_msgs/msg/Twist":
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
    # captured "via `ros2 topic info -v /odom`" (comment beside the constant in an independent
    # rmw_zenoh client) and equal in rosidl-generated hash tables of other projects
    "nav_msgs/msg/Odometry":
        "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
    # share/sensor_msgs/msg/Imu.json `type_hashes` of ROS 2 Kilted and Lyrical (quoted in an
    # independent Zenoh client), and a "VERIFIED (ROS2 Jazzy)" constant elsewhere
    "sensor_msgs/msg/Imu":
        "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b",
    # `ros2 topic info -v /global_costmap/voxel_marked_cloud` output (rviz2 on a ROS 2 install)
    "sensor_msgs/msg/PointCloud2":
        "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5",
    # a Jazzy rosbag2 metadata.yaml `type_description_hash` of a /tf topic, quoted in public notes
    "tf2_msgs/msg/TFMessage":
        "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
    # captured "via `ros2 topic info -v`" against ROS 2 (comment beside the constant)
    "rosgraph_msgs/msg/Clock":
        "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564",
    # rosidl-generated golden-hash test tables of independent ROS 2 client libraries
    "ackermann_msgs/msg/AckermannDriveStamped":
        "RIHS01_48ca7612a08d3bb72744fd98b71b7cf2ea24c6ad50fa4e1aa0bbad963c90d8cf",
}


@pytest.mark.parametrize("typename", sorted(PUBLISHED))
def test_rihs01_hashes_equal_ros2s(typename: str) -> None:
    assert ros2.type_hash(typename) == PUBLISHED[typename]


def test_key_expressions_match_the_design_documents_examples() -> None:
    tail = "std_msgs::msg::dds_::String_/" + PUBLISHED["std_msgs/msg/String"]
    assert ros2.topic_key(0, "chatter", "std_msgs/msg/String") == f"0/chatter/{tail}"
    assert ros2.topic_key(0, "/robot1/chatter", "std_msgs/msg/String") == (
        f"0/robot1/chatter/{tail}")
    assert ros2.dds_type_name("sensor_msgs/msg/Imu") == "sensor_msgs::msg::dds_::Imu_"


def test_liveliness_tokens_match_the_design_documents_examples() -> None:
    talker = ros2.NodeName(2, "8b20917502ee955ac4476e0266340d5c", 0, "talker")
    assert ros2.entity_token(talker, 10, ros2.EntityKind.PUBLISHER, "chatter",
                             "std_msgs/msg/String", "::,7:,:,:,,") == (
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
        "std_msgs::msg::dds_::String_/"
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,")
    listener = ros2.NodeName(2, "aac3178e146ba6f1fc6e6a4085e77f21", 0, "listener")
    assert ros2.node_token(listener) == (
        "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener")


def test_attachment_layout() -> None:
    """8 bytes LE sequence number, 8 bytes LE source timestamp, GID length 16, the GID."""
    gid = bytes(range(16))
    raw = ros2.attachment(3, 1_700_000_000_123_456_789, gid)
    assert raw == (b"\x03" + b"\0" * 7 + (1_700_000_000_123_456_789).to_bytes(8, "little")
                   + b"\x10" + gid)
    assert ros2.parse_attachment(raw) == (3, 1_700_000_000_123_456_789, gid)
    with pytest.raises(ValueError, match="33 bytes"):
        ros2.parse_attachment(raw[:-1])


SESSION = "0123456789abcdef0123456789abcdef"
# GIDs as rmw_zenoh computes them: its own simplified_xxhash3.cpp (ros2/rmw_zenoh
# rmw_zenoh_cpp/src/detail/, rolling bfc065f8c80cc3bc4d1963dc44ac5a472460903a) compiled with g++
# and called as liveliness_utils.cpp's Entity does (memcpy low64, then high64); one token of each
# length class of XXH3-128 (17-128, 129-240, over 240 bytes)
RMW_ZENOH_GIDS = {
    "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener":
        "49877999dacb858702d11ac823785912",
    "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
    "std_msgs::msg::dds_::String_/"
    "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,":
        "ac170f31eadcd9ff0cd86d7a17907d1c",
    f"@ros2_lv/0/{SESSION}/0/11/MP/%/%/kartci/%clock/rosgraph_msgs::msg::dds_::Clock_/"
    "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564/::,10:,:,:,,":
        "b1b5f1d605750397f26732c46e44624a",
    f"@ros2_lv/0/{SESSION}/0/12/MP/%/%/kartci/"
    "%kart0%very%long%namespace%of%a%robot%that%makes%the%token%long%velodyne_points/"
    "sensor_msgs::msg::dds_::PointCloud2_/"
    "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5/::,10:,:,:,,":
        "4189535e05dd53cbb260361dc43f122b",
}


@pytest.mark.parametrize("token", sorted(RMW_ZENOH_GIDS))
def test_gid_is_rmw_zenohs(token: str) -> None:
    assert ros2.gid(token).hex() == RMW_ZENOH_GIDS[token]


def test_the_bridges_gid_is_that_of_its_token() -> None:
    kartci = ros2.NodeName(0, SESSION, 0, "kartci")
    token = ros2.entity_token(kartci, 11, ros2.EntityKind.PUBLISHER, "/clock",
                              "rosgraph_msgs/msg/Clock")
    assert ros2.gid(token).hex() == RMW_ZENOH_GIDS[token]


@pytest.mark.skipif(shutil.which("xxhsum") is None, reason="xxhsum (Debian: xxhash) absent")
@pytest.mark.parametrize("token", sorted(RMW_ZENOH_GIDS))
def test_gid_equals_xxhsums_xxh128(token: str) -> None:
    """xxHash's own CLI: `-H2` is XXH3-128 (`-H3` is the 64-bit XXH3), printed as the canonical
    big-endian high64 then low64."""
    out = subprocess.run(["xxhsum", "-H2", "-"], input=token.encode(), capture_output=True,
                         check=True).stdout.split()[0].decode()
    high, low = int(out[:16], 16), int(out[16:], 16)
    assert ros2.gid(token) == struct.pack("<QQ", low, high)


RANGE = "sensor_msgs/msg/Range"
# share/sensor_msgs/msg/Range.json of sensor_msgs 5.3.8 (Jazzy), as quoted by an independent
# rmw_zenoh client that read it from its ROS test image: Range with `float32 variance`
RANGE_HASH = "RIHS01_b42b62562e93cbfe9d42b82fe5994dfa3d63d7d5c90a317981703f7388adff3a"


def sonar() -> Any:
    return msg(RANGE, header=header(1_500_000_000, "lt0/sonar"), radiation_type=0,
               field_of_view=0.5, min_range=0.02, max_range=4.0, range=1.25)


@pytest.mark.parametrize("distro", [d for d in ros2.Distro if d is not ros2.Distro.HUMBLE])
def test_range_has_variance_from_jazzy_on(distro: ros2.Distro) -> None:
    assert ros2.type_hash(RANGE, distro) == RANGE_HASH
    assert ros2.topic_key(0, "/lt0/sonar", RANGE, distro) == (
        f"0/lt0/sonar/sensor_msgs::msg::dds_::Range_/{RANGE_HASH}")
    kartcis = bytes(typestore().serialize_cdr(sonar(), RANGE))  # logs keep Humble's Range
    sent = ros2.serialize(sonar(), distro)
    assert sent == kartcis + struct.pack("<f", 0.0)  # variance 0: unknown
    back = ros2.deserialize(sent, RANGE, distro)
    assert bytes(typestore().serialize_cdr(back, RANGE)) == kartcis


def test_humble_keys_and_tokens_carry_no_type_hash() -> None:
    """rmw_zenoh on Humble (ros2/rmw_zenoh#388) writes `TypeHashNotSupported` where the hash
    goes; the key and token as Humble-compatible clients document them."""
    humble = ros2.Distro.HUMBLE
    assert ros2.topic_key(0, "chatter", "std_msgs/msg/Int32", humble) == (
        "0/chatter/std_msgs::msg::dds_::Int32_/TypeHashNotSupported")
    node = ros2.NodeName(0, SESSION, 0, "mrm_handler", distro=humble)
    assert ros2.entity_token(node, 5, ros2.EntityKind.PUBLISHER, "/system/fail_safe/mrm_state",
                             "std_msgs/msg/Int32", "1:2:1,10:,:,:,,") == (
        f"@ros2_lv/0/{SESSION}/0/5/MP/%/%/mrm_handler/%system%fail_safe%mrm_state/"
        "std_msgs::msg::dds_::Int32_/TypeHashNotSupported/1:2:1,10:,:,:,,")
    assert ros2.serialize(sonar(), humble) == bytes(typestore().serialize_cdr(sonar(), RANGE))


def test_each_distro_has_its_own_definitions() -> None:
    """rosbags' store per distribution (Rolling: Lyrical's, rosbags has none of its own); the
    types a store lacks come from kartci's (kartci_msgs, ackermann_msgs)."""
    stores = {d: ros2.typestore(d) for d in ros2.Distro}
    assert "variance" not in dict(stores[ros2.Distro.HUMBLE].fielddefs[RANGE][1])
    assert "nav_msgs/msg/Goals" not in stores[ros2.Distro.JAZZY].fielddefs  # new in Kilted
    assert "nav_msgs/msg/Goals" in stores[ros2.Distro.KILTED].fielddefs
    assert "nav_msgs/msg/Trajectory" in stores[ros2.Distro.ROLLING].fielddefs  # Lyrical's
    for store in stores.values():
        assert {"kartci_msgs/msg/KartCommand", "ackermann_msgs/msg/AckermannDriveStamped"} <= (
            store.fielddefs.keys())
