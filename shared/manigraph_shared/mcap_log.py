"""Writing and reading manigraph's MCAP logs.

Channels are named by key expression and carry the message's JSON Schema, so Foxglove and the
``mcap`` reader both understand them. The writer closes a chunk and flushes the file at least
every ``flush_interval`` seconds; the reader recovers every complete chunk of a file whose writer
was killed (``kill -9``) mid-write.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import InvalidMagic
from mcap.reader import NonSeekingReader
from mcap.writer import CompressionType, Writer

from manigraph_shared.errors import LogError
from manigraph_shared.messages import Message, key_matches, message_type_for_key
from manigraph_shared.messages.base import PREFIX

PROFILE = "manigraph"


@dataclass(frozen=True)
class LoggedMessage:
    topic: str
    schema: str
    log_time_ns: int
    data: bytes

    def decode(self) -> Message:
        message_type = message_type_for_key(self.topic)
        if message_type is None:
            raise LogError(f"'{self.topic}' is not a key of the manigraph contract")
        return message_type.decode(self.data, self.topic)


class McapLogWriter:
    """Append bus samples to an MCAP file; one channel per key, schema from the contract."""

    def __init__(self, path: Path, flush_interval: float = 0.1) -> None:
        self.path = path
        self.flush_interval = flush_interval
        path.parent.mkdir(parents=True, exist_ok=True)
        self._stream: BinaryIO = path.open("wb")
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="manigraph")
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._last_flush = time.monotonic()
        self.messages_written = 0

    def add_channel(
        self,
        topic: str,
        message_encoding: str,
        schema_name: str,
        schema_encoding: str,
        schema_data: bytes,
    ) -> None:
        """Declare a channel outside the contract (e.g. Foxglove's protobuf types) before its
        first ``write``; contract keys need no declaration."""
        if topic in self._channels:
            return
        if schema_name not in self._schemas:
            self._schemas[schema_name] = self._writer.register_schema(
                name=schema_name, encoding=schema_encoding, data=schema_data
            )
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding=message_encoding, schema_id=self._schemas[schema_name]
        )

    def write(self, topic: str, data: bytes, log_time_ns: int) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._channel_for(topic)
        self._writer.add_message(
            channel_id=channel,
            log_time=log_time_ns,
            publish_time=log_time_ns,
            data=data,
            sequence=self.messages_written,
        )
        self.messages_written += 1
        self.maybe_flush()

    def maybe_flush(self) -> None:
        if time.monotonic() - self._last_flush >= self.flush_interval:
            self.flush()

    def flush(self) -> None:
        """Close the open chunk and push it to the OS: it survives a ``kill -9`` from now on."""
        self._writer.flush()
        self._stream.flush()
        self._last_flush = time.monotonic()

    def close(self) -> None:
        self._writer.finish()
        self._stream.close()

    def _channel_for(self, topic: str) -> int:
        message_type = message_type_for_key(topic)
        schema_id = 0
        if message_type is not None:
            name = message_type.type_name()
            if name not in self._schemas:
                self._schemas[name] = self._writer.register_schema(
                    name=name, encoding="jsonschema", data=message_type.mcap_schema()
                )
            schema_id = self._schemas[name]
        channel = self._writer.register_channel(
            topic=topic, message_encoding="json", schema_id=schema_id
        )
        self._channels[topic] = channel
        return channel


def read_log(
    path: Path,
    topics: Iterable[str] = (),
    exclude: Iterable[str] = (),
) -> Iterator[LoggedMessage]:
    """Every complete message in ``path`` in file order, filtered by key patterns.

    A file cut short by a killed writer yields everything up to its last complete chunk.
    """
    include, skip = list(topics), list(exclude)
    try:
        stream = path.open("rb")
    except OSError as exc:
        raise LogError(f"cannot open {path}: {exc.strerror}") from None
    with stream:
        reader = NonSeekingReader(stream, record_size_limit=None)
        try:
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                if include and not any(key_matches(p, channel.topic) for p in include):
                    continue
                if any(key_matches(p, channel.topic) for p in skip):
                    continue
                yield LoggedMessage(
                    topic=channel.topic,
                    schema=schema.name if schema else "",
                    log_time_ns=message.log_time,
                    data=message.data,
                )
        except InvalidMagic as exc:
            raise LogError(f"{path} is not an MCAP file: {exc}") from None
        except Exception:
            # The writer was killed mid-chunk: everything before that chunk was yielded.
            return


def decode_log(path: Path, topics: Iterable[str] = ()) -> list[Message]:
    """The contract's messages in ``path`` (by default every ``manigraph/**`` channel; other
    channels, such as Foxglove's drawings, are not messages of the contract)."""
    return [item.decode() for item in read_log(path, list(topics) or [f"{PREFIX}/**"])]
