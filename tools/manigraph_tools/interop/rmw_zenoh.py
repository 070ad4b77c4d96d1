"""rmw_zenoh's wire layout, as pure functions: key expressions, attachments, liveliness tokens.

Followed: ``docs/design.md`` of ros2/rmw_zenoh (rolling branch, read at commit 99a6a2bd), the
layout of ``rmw_zenoh_cpp`` since the attachment format change of ros2/rmw_zenoh#601 (0.1.2 for
Humble; Jazzy's 0.2 and later, Rolling):

* **data key**: ``<domain_id>/<fully_qualified_name>/<type_name>/<type_hash>``, the topic name
  without its leading ``/`` (its other ``/`` stay), the type as DDS names it
  (``sensor_msgs::msg::dds_::JointState_``) and its REP-2016 hash (``RIHS01_<sha256 hex>``);
* **payload**: the message in CDR (little-endian, with its 4-byte encapsulation header);
* **attachment**: ``int64`` sequence number, ``int64`` source timestamp (ns since the epoch),
  both little-endian, then the publisher's GID as a byte sequence: one byte holding its length
  (16, zenoh-ext's LEB128 length) and the 16 bytes;
* **liveliness tokens** (for ``ros2 node list`` / ``ros2 topic list``):
  ``@ros2_lv/<domain>/<session_id>/<node_id>/<entity_id>/<kind>/<enclave>/<namespace>/<node>``
  and, for a publisher (``MP``), ``/<mangled topic>/<type_name>/<type_hash>/<qos>`` after it;
  a mangled name has every ``/`` replaced by ``%``, an empty enclave or namespace is ``%``.

Nothing here opens a session: :mod:`.ros2_bridge` puts what these functions build.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass

#: rmw_zenoh's liveliness admin space (a Zenoh verbatim chunk: ``**`` never matches it).
ADMIN_SPACE = "@ros2_lv"
GID_SIZE = 16
_ATTACHMENT = struct.Struct("<qqB16s")
#: Default QoS in rmw_zenoh's compact form (reliability:durability:history,depth:deadline:
#: lifespan:liveliness), all fields at their defaults but a depth of 10.
DEFAULT_QOS = "::,10:,:,:,,"
NODE_KIND, PUBLISHER_KIND = "NN", "MP"


def dds_type_name(msgtype: str) -> str:
    """``sensor_msgs/msg/JointState`` → ``sensor_msgs::msg::dds_::JointState_``."""
    package, kind, name = msgtype.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def check_topic(topic: str) -> str:
    """A fully qualified ROS 2 topic name (``/a/b``), or ``ValueError`` saying why not."""
    if not topic.startswith("/") or topic.endswith("/") or "//" in topic or len(topic) < 2:
        raise ValueError(f"'{topic}' is not a fully qualified topic name like /a/b")
    allowed = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_/")
    if not set(topic) <= allowed:
        raise ValueError(f"'{topic}' has characters other than letters, digits, _ and /")
    return topic


def topic_key(domain_id: int, topic: str, msgtype: str, type_hash: str) -> str:
    """The key expression rmw_zenoh publishes ``topic`` of ``msgtype`` on."""
    return f"{domain_id}/{check_topic(topic)[1:]}/{dds_type_name(msgtype)}/{type_hash}"


def mangle(name: str) -> str:
    """A name inside a liveliness token: every ``/`` becomes ``%``; empty becomes ``%``."""
    return name.replace("/", "%") or "%"


def node_token(domain_id: int, session_id: str, node_id: int, namespace: str, node: str) -> str:
    return "/".join(
        (
            ADMIN_SPACE,
            str(domain_id),
            session_id,
            str(node_id),
            str(node_id),
            NODE_KIND,
            mangle(""),  # no SROS enclave
            mangle(namespace),
            node,
        )
    )


def publisher_token(
    domain_id: int,
    session_id: str,
    node_id: int,
    entity_id: int,
    namespace: str,
    node: str,
    topic: str,
    msgtype: str,
    type_hash: str,
    qos: str = DEFAULT_QOS,
) -> str:
    return "/".join(
        (
            ADMIN_SPACE,
            str(domain_id),
            session_id,
            str(node_id),
            str(entity_id),
            PUBLISHER_KIND,
            mangle(""),
            mangle(namespace),
            node,
            mangle(check_topic(topic)),
            dds_type_name(msgtype),
            type_hash,
            qos,
        )
    )


@dataclass(frozen=True)
class Attachment:
    """What rmw_zenoh attaches to every published sample."""

    sequence_number: int
    source_timestamp_ns: int
    gid: bytes

    def encode(self) -> bytes:
        if len(self.gid) != GID_SIZE:
            raise ValueError(f"gid: must be {GID_SIZE} bytes, got {len(self.gid)}")
        return _ATTACHMENT.pack(self.sequence_number, self.source_timestamp_ns, GID_SIZE, self.gid)

    @classmethod
    def decode(cls, data: bytes) -> Attachment:
        if len(data) != _ATTACHMENT.size:
            raise ValueError(f"attachment: {_ATTACHMENT.size} bytes expected, got {len(data)}")
        sequence, stamp, size, gid = _ATTACHMENT.unpack(data)
        if size != GID_SIZE:
            raise ValueError(f"attachment: gid length {size}, expected {GID_SIZE}")
        return cls(sequence, stamp, gid)


def publisher_gid(session_id: str, entity_id: int) -> bytes:
    """A publisher's 16-byte GID, unique per session and entity (rmw_zenoh hashes its entity
    the same way: the GID only has to be unique and stable for the publisher's life)."""
    return hashlib.sha256(f"{session_id}/{entity_id}".encode()).digest()[:GID_SIZE]
