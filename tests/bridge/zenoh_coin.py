"""A stack that does not answer deterministically, for the tests: at every /clock it answers an
AckermannDriveStamped stamped with the clock's time whose speed depends on the wall clock (the
nanoseconds of the moment it answers). eclipse-zenoh and `struct` only, keys written out by hand
from ros2/rmw_zenoh docs/design.md.

    python zenoh_coin.py NAMESPACE
"""

import json
import os
import struct
import sys
import time
from typing import Any

import zenoh

NS = sys.argv[1]
CLOCK_KEY = ("0/clock/rosgraph_msgs::msg::dds_::Clock_/"
             "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564")
ACK_TYPE = "ackermann_msgs::msg::dds_::AckermannDriveStamped_"
ACK_HASH = "RIHS01_48ca7612a08d3bb72744fd98b71b7cf2ea24c6ad50fa4e1aa0bbad963c90d8cf"
CMD_KEY = f"0/{NS}/ackermann_cmd/{ACK_TYPE}/{ACK_HASH}"
QOS = "::,10:,:,:,,"


def main() -> None:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps([os.environ["KARTCI_ZENOH_ENDPOINT"]]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    s = zenoh.open(conf)
    zid = s.zid()
    keep: list[Any] = [s.liveliness().declare_token(f"@ros2_lv/0/{zid}/0/0/NN/%/%/coin")]
    pub = s.declare_publisher(CMD_KEY, express=True)
    keep += [pub, s.liveliness().declare_token(
        f"@ros2_lv/0/{zid}/0/11/MP/%/%/coin/%{NS}%ackermann_cmd/{ACK_TYPE}/{ACK_HASH}/{QOS}")]

    def clock(sample: zenoh.Sample) -> None:
        sec, nsec = struct.unpack_from("<iI", sample.payload.to_bytes(), 4)
        frame = f"{NS}/base_link".encode() + b"\0"
        body = struct.pack("<iII", sec, nsec, len(frame)) + frame
        body += b"\0" * (-len(body) % 4)
        speed = 1.0 + (time.time_ns() % 1000) / 1000.0  # the wall clock decides
        pub.put(b"\x00\x01\x00\x00" + body + struct.pack("<5f", 0.0, 0.0, speed, 0.0, 0.0),
                attachment=struct.pack("<qqB16s", 1, time.time_ns(), 16, bytes(range(16))))

    keep.append(s.declare_subscriber(CLOCK_KEY, zenoh.handlers.Callback(clock, indirect=False)))
    keep.append(s.liveliness().declare_token(
        f"@ros2_lv/0/{zid}/0/12/MS/%/%/coin/%clock/rosgraph_msgs::msg::dds_::Clock_/"
        f"{CLOCK_KEY.rsplit('/', 1)[1]}/{QOS}"))
    while keep:
        time.sleep(1)


main()
