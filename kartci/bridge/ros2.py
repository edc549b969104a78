"""rmw_zenoh's wire conventions: key expressions, DDS type names, RIHS01 type hashes, the
attachment, GIDs and liveliness tokens (ros2/rmw_zenoh `docs/design.md`; docs/howto/ros2-zenoh.md
names the commit they were taken from), and the message definitions of the ROS 2 distribution
the stack runs.

Pure functions of names, numbers and messages, no Zenoh import: the conventions are tested on
their own.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import Enum
from functools import cache
from typing import Any

import xxhash
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from kartci.bridge.lockstep import Durability, Qos, Reliability
from kartci.logs.types import typestore as kartci_store

LIVELINESS_PREFIX = "@ros2_lv"
DEFAULT_QOS = "::,10:,:,:,,"  # default reliability and durability, KEEP_LAST 10, the rest default
_ATTACHMENT = struct.Struct("<qqB16s")  # sequence number, source timestamp (ns), GID length, GID
_GID = struct.Struct("<QQ")  # XXH128_hash_t {low64, high64} as memcpy'd on a little-endian host
NO_TYPE_HASH = "TypeHashNotSupported"  # rmw_zenoh on Humble (no REP 2011 there), keys and tokens


class Distro(Enum):
    """The ROS 2 distribution of the stack: its message definitions and rmw_zenoh's key format."""

    HUMBLE = "humble"
    JAZZY = "jazzy"
    KILTED = "kilted"
    LYRICAL = "lyrical"
    ROLLING = "rolling"


DEFAULT_DISTRO = Distro.JAZZY
# rosbags' store of each distribution's standard messages. rosbags has no Rolling store:
# Lyrical's, the release last branched from Rolling, is the nearest (a type changed in Rolling
# since then is not known to kartci)
_STORES = {Distro.HUMBLE: Stores.ROS2_HUMBLE, Distro.JAZZY: Stores.ROS2_JAZZY,
           Distro.KILTED: Stores.ROS2_KILTED, Distro.LYRICAL: Stores.ROS2_LYRICAL,
           Distro.ROLLING: Stores.ROS2_LYRICAL}


@cache
def typestore(distro: Distro) -> Typestore:
    """The message definitions a stack on `distro` uses: rosbags' store of that distribution,
    plus the types it lacks from kartci's own store (ackermann_msgs, vision_msgs, kartci_msgs)."""
    store = get_typestore(_STORES[distro])
    store.register({k: v for k, v in kartci_store().fielddefs.items()
                    if k not in store.fielddefs})
    return store


@cache
def _differs(typename: str, distro: Distro) -> bool:
    """Whether `distro` defines a type otherwise than kartci's store (logs and the loop)."""
    return bool(kartci_store().hash_rihs01(typename) != typestore(distro).hash_rihs01(typename))


def _zero(node: tuple[Nodetype, Any], into: Typestore) -> Any:
    """The value of a field the other definition lacks: 0, "", or a message of them."""
    kind, detail = node
    if kind is Nodetype.NAME:
        return into.types[detail](**{name: _zero(sub, into)
                                     for name, sub in into.fielddefs[detail][1]})
    if kind is Nodetype.BASE:
        return "" if detail[0] in ("string", "wstring") else 0
    raise ValueError(f"no zero value for a missing field of kind {kind.name}")


def _convert(message: Any, into: Typestore, distro: Distro) -> Any:
    """`message` as a message of `into`'s definition of its type, field by field where the
    definitions differ (a field `into` lacks is dropped, one it adds is zero)."""
    typename = message.__msgtype__
    if not _differs(typename, distro):
        return message
    fields = {}
    for name, node in into.fielddefs[typename][1]:
        if not hasattr(message, name):
            fields[name] = _zero(node, into)
        elif node[0] is Nodetype.NAME:
            fields[name] = _convert(getattr(message, name), into, distro)
        elif node[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) and node[1][0][0] is Nodetype.NAME:
            fields[name] = [_convert(m, into, distro) for m in getattr(message, name)]
        else:
            fields[name] = getattr(message, name)
    return into.types[typename](**fields)


def serialize(message: Any, distro: Distro) -> bytes:
    """CDR of a message of kartci's store as `distro` defines its type (Range on Jazzy and
    later: `variance` 0, "unknown")."""
    store = typestore(distro)
    return bytes(store.serialize_cdr(_convert(message, store, distro), message.__msgtype__))


def deserialize(payload: bytes, typename: str, distro: Distro) -> Any:
    """A CDR payload of `distro`'s `typename` as a message of kartci's store."""
    return _convert(typestore(distro).deserialize_cdr(payload, typename), kartci_store(), distro)


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


def ros_type_name(dds_name: str) -> str:
    """`sensor_msgs::msg::dds_::Imu_` -> `sensor_msgs/msg/Imu` (another name is kept)."""
    parts = dds_name.split("::")
    if len(parts) == 4 and parts[2] == "dds_" and parts[3].endswith("_"):
        return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"
    return dds_name


@cache
def type_hash(typename: str, distro: Distro = DEFAULT_DISTRO) -> str:
    """The RIHS01 hash (REP 2011) of `distro`'s definition of a type (Humble: no hash)."""
    if distro is Distro.HUMBLE:
        return NO_TYPE_HASH
    return str(typestore(distro).hash_rihs01(typename))


def fully_qualified(topic: str) -> str:
    """A topic name with its leading slash (`odom` relative names are resolved by the caller)."""
    return topic if topic.startswith("/") else f"/{topic}"


def mangle(name: str) -> str:
    """A name with every `/` replaced by `%` (an empty name is `%`)."""
    return name.replace("/", "%") or "%"


def topic_key(domain_id: int, topic: str, typename: str,
              distro: Distro = DEFAULT_DISTRO) -> str:
    """`<domain_id>/<fully_qualified_name without its leading slash>/<type_name>/<type_hash>`."""
    return (f"{domain_id}/{fully_qualified(topic)[1:]}/{dds_type_name(typename)}/"
            f"{type_hash(typename, distro)}")


@dataclass(frozen=True)
class NodeName:
    """Who a liveliness token speaks for: the session, the node's id, namespace and name."""

    domain_id: int
    session_id: str  # the Zenoh session id (hex)
    node_id: int
    name: str
    namespace: str = ""  # "" or "/ns"
    enclave: str = ""
    distro: Distro = DEFAULT_DISTRO  # the type hashes its tokens carry


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
            f"{type_hash(typename, node.distro)}/{qos}")


def qos_text(qos: Qos) -> str:
    """A QoS as rmw_zenoh writes it into a token (`<reliability>:<durability>:<history>,<depth>:
    <deadline>:<lifespan>:<liveliness>`, a field empty at rmw's default: reliable, volatile,
    keep last)."""
    rel = "" if qos.reliable else str(Reliability.BEST_EFFORT.value)
    dur = str(Durability.TRANSIENT_LOCAL.value) if qos.latched else ""
    return f"{rel}:{dur}:,{qos.depth}:,:,:,,"


def parse_qos(text: str) -> Qos:
    """The reliability, durability and depth of a token's QoS field (defaults where empty or
    unreadable: a token from another implementation still names its endpoint)."""
    fields = text.split(":")
    def number(i: int, default: int) -> int:
        try:
            return int(fields[i].split(",")[-1] if i == 2 else fields[i])
        except (IndexError, ValueError):
            return default
    rel, dur = number(0, 1), number(1, 2)
    return Qos(Reliability.BEST_EFFORT if rel == 2 else Reliability.RELIABLE,
               Durability.TRANSIENT_LOCAL if dur == 1 else Durability.VOLATILE, number(2, 10))


def gid(token: str) -> bytes:
    """An entity's 16-byte GID as rmw_zenoh computes it (liveliness_utils.cpp, `Entity`): the
    XXH3-128 of its liveliness token, the low 64 bits then the high 64, little endian, so it
    equals what `ros2 topic info -v` shows for it."""
    h = xxhash.xxh3_128_intdigest(token.encode())
    return _GID.pack(h & 0xFFFF_FFFF_FFFF_FFFF, h >> 64)


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
