"""rmw_zenoh's key layout and attachment, checked against the examples of its docs/design.md
(rolling, commit 99a6a2bd) and against zenoh-ext's own serializer, which rmw_zenoh uses."""

from __future__ import annotations

import pytest
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

from manigraph_tools.interop.rmw_zenoh import (
    Attachment,
    node_token,
    publisher_gid,
    publisher_token,
    topic_key,
)

STORE = get_typestore(Stores.ROS2_JAZZY)
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"


def test_the_type_hash_is_the_one_rmw_zenoh_documents() -> None:
    assert STORE.hash_rihs01("std_msgs/msg/String") == STRING_HASH


@pytest.mark.parametrize(
    ("domain", "topic", "documented"),
    [
        (0, "/chatter", f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"),
        (0, "/robot1/chatter", f"0/robot1/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"),
    ],
)
def test_topic_keys_are_the_documented_ones(domain: int, topic: str, documented: str) -> None:
    assert topic_key(domain, topic, "std_msgs/msg/String", STRING_HASH) == documented


def test_the_joint_state_key() -> None:
    hash_ = STORE.hash_rihs01("sensor_msgs/msg/JointState")
    assert (
        topic_key(3, "/manigraph/joint_states", "sensor_msgs/msg/JointState", hash_)
        == f"3/manigraph/joint_states/sensor_msgs::msg::dds_::JointState_/{hash_}"
    )


@pytest.mark.parametrize("topic", ["chatter", "/a//b", "/a/", "/a b", "/"])
def test_a_name_that_is_not_a_fully_qualified_topic_is_refused(topic: str) -> None:
    with pytest.raises(ValueError, match=r"topic name|characters"):
        topic_key(0, topic, "std_msgs/msg/String", STRING_HASH)


def test_liveliness_tokens_are_the_documented_ones() -> None:
    assert (
        node_token(2, "aac3178e146ba6f1fc6e6a4085e77f21", 0, "", "listener")
        == "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
    )
    assert publisher_token(
        2,
        "8b20917502ee955ac4476e0266340d5c",
        0,
        10,
        "",
        "talker",
        "/chatter",
        "std_msgs/msg/String",
        STRING_HASH,
        qos="::,7:,:,:,,",
    ) == (
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
        f"std_msgs::msg::dds_::String_/{STRING_HASH}/::,7:,:,:,,"
    )


def test_the_attachment_is_what_zenoh_ext_serializes() -> None:
    gid = publisher_gid("8b20917502ee955ac4476e0266340d5c", 10)
    attachment = Attachment(
        sequence_number=42, source_timestamp_ns=1_767_000_000_123_456_789, gid=gid
    )
    encoded = attachment.encode()
    assert len(encoded) == 8 + 8 + 1 + 16
    reference = zenoh.ext.z_serialize(
        (zenoh.ext.Int64(42), zenoh.ext.Int64(1_767_000_000_123_456_789), gid)
    ).to_bytes()
    assert encoded == reference
    sequence, stamp, decoded_gid = zenoh.ext.z_deserialize(
        tuple[zenoh.ext.Int64, zenoh.ext.Int64, bytes], zenoh.ZBytes(encoded)
    )
    assert (int(sequence), int(stamp), decoded_gid) == (42, 1_767_000_000_123_456_789, gid)
    assert Attachment.decode(encoded) == attachment


def test_gids_differ_per_publisher_and_a_bad_one_is_refused() -> None:
    assert publisher_gid("s", 1) != publisher_gid("s", 2) != publisher_gid("t", 2)
    with pytest.raises(ValueError, match="gid"):
        Attachment(1, 0, b"short").encode()
    with pytest.raises(ValueError, match="33 bytes"):
        Attachment.decode(b"\x00" * 20)
