"""A stack of two processes for the tests, as a team's launch file starts them: a planner that
turns each /clock into a `/<ns>/plan` message, and a driver that answers each plan with an
AckermannDriveStamped (zero speed) stamped with the plan's time. Both connect only to
$KARTCI_ZENOH_ENDPOINT (loopback, multicast off, gossip on as in rmw_zenoh's default config):
the plan reaches the driver only if kartci's session gossips their endpoints to each other.
eclipse-zenoh and `struct` only, no kartci import; keys written out by hand from
ros2/rmw_zenoh docs/design.md.

    python zenoh_two_stage.py NAMESPACE            (the launcher: starts both, waits)
    python zenoh_two_stage.py NAMESPACE planner|driver
"""

import json
import os
import struct
import subprocess
import sys
import time
from typing import Any

import zenoh

NS = sys.argv[1]
CLOCK_TYPE = "rosgraph_msgs::msg::dds_::Clock_"
CLOCK_HASH = "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564"
CLOCK_KEY = f"0/clock/{CLOCK_TYPE}/{CLOCK_HASH}"
PLAN_KEY = f"0/{NS}/plan/{CLOCK_TYPE}/{CLOCK_HASH}"  # a Clock message as the plan: its stamp
ACK_TYPE = "ackermann_msgs::msg::dds_::AckermannDriveStamped_"
ACK_HASH = "RIHS01_48ca7612a08d3bb72744fd98b71b7cf2ea24c6ad50fa4e1aa0bbad963c90d8cf"
CMD_KEY = f"0/{NS}/ackermann_cmd/{ACK_TYPE}/{ACK_HASH}"
QOS = "::,10:,:,:,,"


def session() -> zenoh.Session:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([os.environ["KARTCI_ZENOH_ENDPOINT"]]))
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "true")
    return zenoh.open(conf)


def token(s: zenoh.Session, node: str, entity: int, kind: str, topic: str, key: str) -> Any:
    typename, hash_ = key.rsplit("/", 2)[1:]
    return s.liveliness().declare_token(
        f"@ros2_lv/0/{s.zid()}/0/{entity}/{kind}/%/%/{node}/{topic.replace('/', '%')}/"
        f"{typename}/{hash_}/{QOS}")


def ackermann(t_ns: int) -> bytes:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    frame = f"{NS}/base_link".encode() + b"\0"
    body = struct.pack("<iII", sec, nsec, len(frame)) + frame
    body += b"\0" * (-len(body) % 4)
    return b"\x00\x01\x00\x00" + body + struct.pack("<5f", 0.0, 0.0, 0.0, 0.0, 0.0)


def attachment(seq: int) -> bytes:
    return struct.pack("<qqB16s", seq, time.time_ns(), 16, bytes(range(16)))


def planner() -> list[Any]:
    """Declares its /clock subscription only once the driver has subscribed to the plan, so
    tick 0 is answered (a launch order a test can rely on)."""
    s = session()
    keep: list[Any] = [s, s.liveliness().declare_token(f"@ros2_lv/0/{s.zid()}/0/0/NN/%/%/planner")]
    pub = s.declare_publisher(PLAN_KEY, express=True)
    keep += [pub, token(s, "planner", 11, "MP", f"/{NS}/plan", PLAN_KEY)]
    status: Any = pub.matching_status  # a MatchingStatus; the stub says bool
    while not status.matching:
        time.sleep(0.01)
        status = pub.matching_status
    seq = [0]

    def clock(sample: zenoh.Sample) -> None:
        seq[0] += 1
        pub.put(sample.payload.to_bytes(), attachment=attachment(seq[0]))

    keep.append(s.declare_subscriber(CLOCK_KEY, zenoh.handlers.Callback(clock, indirect=False)))
    keep.append(token(s, "planner", 12, "MS", "/clock", CLOCK_KEY))
    return keep


def driver() -> list[Any]:
    s = session()
    keep: list[Any] = [s, s.liveliness().declare_token(f"@ros2_lv/0/{s.zid()}/0/0/NN/%/%/driver")]
    pub = s.declare_publisher(CMD_KEY, express=True)
    keep += [pub, token(s, "driver", 11, "MP", f"/{NS}/ackermann_cmd", CMD_KEY)]
    seq = [0]

    def plan(sample: zenoh.Sample) -> None:
        sec, nsec = struct.unpack_from("<iI", sample.payload.to_bytes(), 4)
        seq[0] += 1
        pub.put(ackermann(sec * 1_000_000_000 + nsec), attachment=attachment(seq[0]))

    keep.append(s.declare_subscriber(PLAN_KEY, zenoh.handlers.Callback(plan, indirect=False)))
    keep.append(token(s, "driver", 12, "MS", f"/{NS}/plan", PLAN_KEY))
    return keep


def main() -> None:
    if len(sys.argv) == 2:  # the launcher; kartci stops the process group, both with it
        procs = [subprocess.Popen([sys.executable, __file__, NS, role])
                 for role in ("driver", "planner")]
        sys.exit(max(p.wait() for p in procs))
    keep = planner() if sys.argv[2] == "planner" else driver()
    while keep:
        time.sleep(1)


main()
