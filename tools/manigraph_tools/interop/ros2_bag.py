"""A manigraph log as a ROS 2 bag: MCAP storage, CDR messages, ``ros2msg`` schemas.

The bag is written with rosbags' writer (format version 9, the one of ROS 2 Jazzy's
``ros2 bag``) and the message definitions of ROS 2 Jazzy; what becomes which topic and type is
:mod:`.ros2_messages`. Each message's **bag timestamp is the source message's log time** (when
the recorder received it); each ROS header's stamp is the contract message's own ``stamp``.

The summary :func:`export_ros2` returns says what was written per ROS 2 topic, what was read
per source topic, which source topics have no ROS 2 form (``skipped``), the messages that did
not validate (``invalid``), and, for a log whose writer was killed, where it stopped.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Literal, TextIO

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.writer import Connection

from manigraph_shared.messages import (
    CameraInfo,
    CompressedImage,
    JointState,
    Message,
    Scene,
)
from manigraph_tools.interop.ros2_messages import AS_JSON, ROS_DISTRO, Converter, typestore
from manigraph_tools.interop.source import SourceLog, check_paths, choose_cell

#: The contract types that have a ROS 2 form.
EXPORTED: tuple[type[Message], ...] = (Scene, JointState, CompressedImage, CameraInfo, *AS_JSON)
#: rosbag2's metadata format version written (9: ROS 2 Jazzy and later).
BAG_VERSION: Literal[9] = 9
#: A progress line per this many source messages.
PROGRESS_EVERY = 50_000


def export_ros2(
    log: Path, out: Path, progress: TextIO, cell: str | None = None
) -> dict[str, object]:
    """Write the ROS 2 bag of ``log``'s robot cell ``cell`` (:func:`choose_cell`) into the
    folder ``out`` (new, or empty)."""
    check_paths(log, out)
    source = SourceLog(log, choose_cell(log, cell))
    if out.is_dir():
        out.rmdir()  # empty (checked): rosbags creates the bag's folder itself
    converter = Converter()
    store = typestore()
    written: Counter[str] = Counter()
    types: dict[str, str] = {}
    connections: dict[str, Connection] = {}
    writer = Writer(out, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
    with writer:
        for item, message in source.messages(EXPORTED):
            for ros in converter.convert(message):
                connection = connections.get(ros.topic)
                if connection is None:
                    connection = writer.add_connection(ros.topic, ros.msgtype, typestore=store)
                    connections[ros.topic] = connection
                    types[ros.topic] = ros.msgtype
                writer.write(connection, item.log_time_ns, ros.cdr())
                written[ros.topic] += 1
            if source.messages_read % PROGRESS_EVERY == 0:
                print(f"ros2: {source.messages_read} messages read", file=progress, flush=True)
    exported_topics = {topic for topic in source.read_per_topic if _type_exported(source, topic)}
    summary: dict[str, object] = {
        "format": "ros2",
        "log": str(log),
        "cell": source.cell,
        "bag": str(out),
        "storage": "mcap",
        "serialization": "cdr",
        "ros_distro": ROS_DISTRO.value,
        "messages_read": source.messages_read,
        "messages_written": sum(written.values()),
        "topics": {topic: {"type": types[topic], "count": written[topic]} for topic in written},
        "read": dict(source.read_per_topic),
        "skipped": {
            topic: count
            for topic, count in source.read_per_topic.items()
            if topic not in exported_topics
        },
        "invalid": dict(source.invalid_per_topic),
        "truncated": source.stopped(),
    }
    print(
        f"ros2: wrote {summary['messages_written']} messages on {len(written)} topics to {out}",
        file=progress,
        flush=True,
    )
    return summary


def _type_exported(source: SourceLog, topic: str) -> bool:
    message_type = source.type_of(topic)
    return message_type is not None and issubclass(message_type, EXPORTED)
