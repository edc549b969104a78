"""rmw_zenoh's wire conventions: key expressions, DDS type names, RIHS01 type hashes, the
attachment and liveliness tokens (ros2/rmw_zenoh `docs/design.md`, see the README's bridge
section for the commit they were taken from).

Pure functions of names and numbers, no Zenoh import: the conventions are tested on their own.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass
from enum import Enum
from functools import cache

from kartci.logs.types import typestore

LIVELINESS_PREFIX = "@ros2_lv"
DEFAULT_QOS = "::,10:,:,:,,"  # default reliability and durability, KEEP_LAST 10, the rest default
_ATTACHMENT = struct.Struct("<qqB16s")  # sequence number, source timestamp (ns), GID length, GID


class EntityKind(Enum):
    """An entity's two-letter kind in a liveliness token."""

    NODE = "NN"
    PUBLISHER = "MP"
    SUBSCRIPTION = "MS"


def dds_type_name(typename: str) -> str:
    """`sensor_msgs/msg/Imu` -> `sensor_msgs::msg::dds_::Imu_` (the type name as DDS declares
    it for CDR, which rmw_zenoh puts in keys and tokens)."""
    package, kind, name = typename.split("/")
    return f"{package}::{kind}::dds_::{name}_"


@cache
def type_hash(typename: str) -> str:
    """The RIHS01 hash (REP 2011) of a message definition in kartci's type store."""
    return str(typestore().hash_rihs01(typename))


def fully_qualified(topic: str) -> str:
    """A topic name with its leading slash (`odom` relative names are resolved by the caller)."""
    return topic if topic.startswith("/") else f"/{topic}"


def mangle(name: str) -> str:
    """A name with every `/` replaced by `%` (an empty name is `%`)."""
    return name.replace("/", "%") or "%"


def topic_key(domain_id: int, topic: str, typename: str) -> str:
    """`<domain_id>/<fully_qualified_name without its leading slash>/<type_name>/<type_hash>`."""
    return (f"{domain_id}/{fully_qualified(topic)[1:]}/{dds_type_name(typename)}/"
            f"{type_hash(typename)}")


@dataclass(frozen=True)
class NodeName:
    """Who a liveliness token speaks for: the session, the node's id, namespace and name."""

    domain_id: int
    session_id: str  # the Zenoh session id (hex)
    node_id: int
    name: str
    namespace: str = ""  # "" or "/ns"
    enclave: str = ""


def node_token(node: NodeName) -> str:
    """`@ros2_lv/<domain>/<session>/<node_id>/<node_id>/NN/<enclave>/<namespace>/<node_name>`."""
    return (f"{LIVELINESS_PREFIX}/{node.domain_id}/{node.session_id}/{node.node_id}/"
            f"{node.node_id}/{EntityKind.NODE.value}/{mangle(node.enclave)}/"
            f"{mangle(node.namespace)}/{node.name}")


def entity_token(node: NodeName, entity_id: int, kind: EntityKind, topic: str, typename: str,
                 qos: str = DEFAULT_QOS) -> str:
    """The liveliness token of a publisher (`MP`) or subscription (`MS`) of `node`."""
    return (f"{LIVELINESS_PREFIX}/{node.domain_id}/{node.session_id}/{node.node_id}/"
            f"{entity_id}/{kind.value}/{mangle(node.enclave)}/{mangle(node.namespace)}/"
            f"{node.name}/{mangle(fully_qualified(topic))}/{dds_type_name(typename)}/"
            f"{type_hash(typename)}/{qos}")


def gid(session_id: str, entity_id: int) -> bytes:
    """A publisher's 16-byte GID: unique per session and entity (as rmw_zenoh's are)."""
    return hashlib.sha256(f"{session_id}/{entity_id}".encode()).digest()[:16]


def attachment(sequence: int, source_ns: int, publisher_gid: bytes) -> bytes:
    """int64 LE sequence number, int64 LE source timestamp (ns since the UNIX epoch), one byte
    GID length (16) and the GID."""
    return _ATTACHMENT.pack(sequence, source_ns, len(publisher_gid), publisher_gid)


def parse_attachment(data: bytes) -> tuple[int, int, bytes]:
    """(sequence number, source timestamp ns, GID) of an attachment; ValueError when malformed."""
    if len(data) != _ATTACHMENT.size:
        raise ValueError(f"an rmw_zenoh attachment has {_ATTACHMENT.size} bytes, not "
                         f"{len(data)}")
    seq, stamp, n, g = _ATTACHMENT.unpack(data)
    if n != 16:
        raise ValueError(f"attachment GID length {n}, expected 16")
    return seq, stamp, g
