"""An independent rmw_zenoh-convention stack for the tests: eclipse-zenoh and `struct` only, no
kartci import, every key written out by hand from ros2/rmw_zenoh docs/design.md.

It connects to $KARTCI_ZENOH_ENDPOINT, records every sample of `/clock` and `/<ns>/odom` (key,
attachment, stamp) and every liveliness token it sees, and answers each /clock with an
AckermannDriveStamped (zero speed) stamped with the clock's time, CDR-encoded by hand. On SIGTERM
it writes what it saw as JSON to argv[1].

    python zenoh_listener.py OUT.json NAMESPACE [humble]

With `humble` it speaks as rmw_zenoh on Humble does: `TypeHashNotSupported` where the hash goes.
"""

import json
import os
import signal
import struct
import sys
import threading
import time
from pathlib import Path
from typing import Any

import zenoh

OUT, NS = sys.argv[1], sys.argv[2]
HUMBLE = sys.argv[3:] == ["humble"]


def hashed(rihs01: str) -> str:
    return "TypeHashNotSupported" if HUMBLE else rihs01


CLOCK_KEY = ("0/clock/rosgraph_msgs::msg::dds_::Clock_/"
             + hashed("RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564"))
ODOM_KEY = (f"0/{NS}/odom/nav_msgs::msg::dds_::Odometry_/"
            + hashed("RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"))
ACK_TYPE = "ackermann_msgs::msg::dds_::AckermannDriveStamped_"
ACK_HASH = hashed("RIHS01_48ca7612a08d3bb72744fd98b71b7cf2ea24c6ad50fa4e1aa0bbad963c90d8cf")
CMD_KEY = f"0/{NS}/ackermann_cmd/{ACK_TYPE}/{ACK_HASH}"
QOS = "::,10:,:,:,,"

seen: dict[str, list[Any]] = {"clock": [], "odom": [], "tokens": []}
lock = threading.Lock()


def attachment(sample: zenoh.Sample) -> dict[str, int]:
    raw = sample.attachment.to_bytes() if sample.attachment is not None else b""
    seq, source_ns, n = struct.unpack_from("<qqB", raw) if len(raw) == 33 else (-1, -1, -1)
    return {"len": len(raw), "seq": seq, "source_ns": source_ns, "gid_len": n,
            "gid": raw[17:33].hex()}


def stamp(payload: bytes, offset: int = 4) -> int:  # after the 4-byte CDR encapsulation header
    sec, nsec = struct.unpack_from("<iI", payload, offset)
    return int(sec) * 1_000_000_000 + int(nsec)


def ackermann(t_ns: int) -> bytes:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    frame = f"{NS}/base_link".encode() + b"\0"
    body = struct.pack("<iII", sec, nsec, len(frame)) + frame
    body += b"\0" * (-len(body) % 4)
    return b"\x00\x01\x00\x00" + body + struct.pack("<5f", 0.0, 0.0, 0.0, 0.0, 0.0)


def main() -> None:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([os.environ["KARTCI_ZENOH_ENDPOINT"]]))
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "false")
    s = zenoh.open(conf)
    zid = str(s.zid())

    def write(*_: object) -> None:
        with lock:
            Path(OUT).write_text(json.dumps(seen))
        os._exit(0)

    signal.signal(signal.SIGTERM, write)

    def token(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            with lock:
                seen["tokens"].append(str(sample.key_expr))

    keep: list[Any] = [s.liveliness().declare_subscriber("@ros2_lv/**", token, history=True)]
    keep.append(s.liveliness().declare_token(f"@ros2_lv/0/{zid}/0/0/NN/%/%/listener"))

    def odom(sample: zenoh.Sample) -> None:
        with lock:
            seen["odom"].append({"key": str(sample.key_expr), "stamp": stamp(
                sample.payload.to_bytes()), **attachment(sample)})

    keep.append(s.declare_subscriber(ODOM_KEY, zenoh.handlers.Callback(odom, indirect=False)))
    keep.append(s.liveliness().declare_token(
        f"@ros2_lv/0/{zid}/0/11/MS/%/%/listener/%{NS}%odom/nav_msgs::msg::dds_::Odometry_/"
        f"{ODOM_KEY.rsplit('/', 1)[1]}/{QOS}"))
    pub = s.declare_publisher(CMD_KEY, express=True)
    keep.append(s.liveliness().declare_token(
        f"@ros2_lv/0/{zid}/0/12/MP/%/%/listener/%{NS}%ackermann_cmd/{ACK_TYPE}/{ACK_HASH}/{QOS}"))
    gid = bytes(range(16))
    count = [0]

    def clock(sample: zenoh.Sample) -> None:
        t = stamp(sample.payload.to_bytes())
        with lock:
            seen["clock"].append({"key": str(sample.key_expr), "stamp": t, **attachment(sample)})
        count[0] += 1
        pub.put(ackermann(t), attachment=struct.pack("<qqB16s", count[0], time.time_ns(), 16,
                                                     gid))

    keep.append(s.declare_subscriber(CLOCK_KEY, zenoh.handlers.Callback(clock, indirect=False)))
    keep.append(s.liveliness().declare_token(
        f"@ros2_lv/0/{zid}/0/13/MS/%/%/listener/%clock/rosgraph_msgs::msg::dds_::Clock_/"
        f"{CLOCK_KEY.rsplit('/', 1)[1]}/{QOS}"))
    while True:
        time.sleep(1)


main()
