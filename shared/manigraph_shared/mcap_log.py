"""Writing and reading manigraph's MCAP logs.

Channels are named by key expression and carry the message's JSON Schema, so Foxglove and the
``mcap`` reader both understand them. The writer closes a chunk and flushes the file at least
every ``flush_interval`` seconds; the reader recovers every complete chunk of a file whose writer
was killed (``kill -9``) mid-write, and :func:`recover_log` rewrites such a file as a finalised
MCAP file (summary, indexes, footer) that any standard reader opens.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import InvalidMagic
from mcap.reader import NonSeekingReader
from mcap.records import Channel, Header, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from manigraph_shared.cells import cell_of, default_key
from manigraph_shared.errors import LogError
from manigraph_shared.mcap_index import bound_chunk_indexes
from manigraph_shared.messages import (
    CONTRACT_VERSION,
    Message,
    key_matches,
    message_type_for_key,
)
from manigraph_shared.messages.base import PREFIX

PROFILE = "manigraph"
#: The header's ``library``: this, then the contract version (``manigraph 2``).
LIBRARY = "manigraph"


@dataclass(frozen=True)
class LoggedMessage:
    topic: str
    schema: str
    log_time_ns: int
    data: bytes

    @property
    def cell(self) -> str | None:
        """The robot cell the message came from (``None``: the default cell)."""
        return cell_of(self.topic)

    def decode(self) -> Message:
        message_type = message_type_for_key(default_key(self.topic))
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
        # One chunk per flush (100 ms): its index waits for the summary on disk, not in memory.
        self._chunk_indexes = bound_chunk_indexes(self._writer, path.parent)
        self._writer.start(profile=PROFILE, library=f"{LIBRARY} {CONTRACT_VERSION}")
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._last_flush = time.monotonic()
        self.messages_written = 0
        self._unflushed = 0  # bytes of messages in the open chunk

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
        self._unflushed += len(data)
        self.maybe_flush()

    def maybe_flush(self) -> None:
        if time.monotonic() - self._last_flush >= self.flush_interval:
            self.flush()

    def flush(self) -> None:
        """Close the open chunk and push it to the OS: it survives a ``kill -9`` from now on."""
        self._writer.flush()
        self._stream.flush()
        self._last_flush = time.monotonic()
        self._unflushed = 0

    @property
    def bytes_written(self) -> int:
        """Bytes in the file so far (the open chunk not counted until flushed)."""
        return self._stream.tell()

    @property
    def size(self) -> int:
        """Bytes in the file plus the messages of the open chunk: what the file will hold
        once that chunk is flushed (rotation by size uses this, so a burst written between
        two flushes cannot grow one file past its limit)."""
        return self._stream.tell() + self._unflushed

    def close(self) -> None:
        self._writer.finish()
        self._stream.close()
        self._chunk_indexes.close()

    def _channel_for(self, topic: str) -> int:
        # A cell's key (manigraph/<cell>/world/scene) has its default-cell key's schema.
        message_type = message_type_for_key(default_key(topic))
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
        except InvalidMagic:  # its own words list the first bytes: "invalid magic: (35, ...)"
            raise LogError(f"not an MCAP file: {path}") from None
        except Exception:
            # The writer was killed mid-chunk: everything before that chunk was yielded.
            return


def decode_log(path: Path, topics: Iterable[str] = ()) -> list[Message]:
    """The contract's messages in ``path`` (by default every ``manigraph/**`` channel; other
    channels, such as Foxglove's drawings, are not messages of the contract)."""
    return [item.decode() for item in read_log(path, list(topics) or [f"{PREFIX}/**"])]


def contract_version(path: Path) -> int:
    """The contract version a log was written with (its header's ``library``); 1 for logs
    written before versions were recorded. ``LogError`` for a file that is not MCAP."""
    try:
        with path.open("rb") as stream:
            header = next(iter(StreamReader(stream).records), None)  # the first record
    except OSError as exc:
        raise LogError(f"cannot open {path}: {exc.strerror}") from None
    except Exception:
        raise LogError(f"not an MCAP file: {path}") from None
    if not isinstance(header, Header):
        raise LogError(f"not an MCAP file: {path}")
    prefix = f"{LIBRARY} "
    if header.library.startswith(prefix):
        version = header.library.removeprefix(prefix).split(" ")[0]
        if version.isdigit():
            return int(version)
    return 1


#: The 8 bytes every MCAP file starts and a finalised one ends with.
MCAP_MAGIC = b"\x89MCAP0\r\n"


def is_finalised(path: Path) -> bool:
    """Whether ``path`` ends with the MCAP magic (its writer finished it)."""
    try:
        with path.open("rb") as stream:
            stream.seek(0, os.SEEK_END)
            if stream.tell() < 2 * len(MCAP_MAGIC):
                return False
            stream.seek(-len(MCAP_MAGIC), os.SEEK_END)
            return stream.read() == MCAP_MAGIC
    except OSError as exc:
        raise LogError(f"cannot open {path}: {exc.strerror}") from None


def recover_log(path: Path, output: Path | None = None) -> int:
    """Rewrite ``path`` (cut short by a killed writer) as a finalised MCAP file.

    Every message of every complete chunk is kept, with its channel, schema, times and
    sequence. Written to ``output``, or (without one) to a temporary file that then replaces
    ``path``, so the file is never half-repaired. Returns the number of messages kept.
    """
    target = output or path.with_name(path.name + ".recovering")
    try:
        source = path.open("rb")
    except OSError as exc:
        raise LogError(f"cannot open {path}: {exc.strerror}") from None
    kept = 0
    with source, target.open("wb") as sink:
        writer = Writer(sink, compression=CompressionType.ZSTD)
        chunk_indexes = bound_chunk_indexes(writer, target.parent)
        writer.start(profile=PROFILE, library="manigraph (recovered)")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        reader = NonSeekingReader(source, record_size_limit=None)
        try:
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                if channel.id not in channels:
                    channels[channel.id] = _copy_channel(writer, schema, channel, schemas)
                writer.add_message(
                    channel_id=channels[channel.id],
                    log_time=message.log_time,
                    publish_time=message.publish_time,
                    data=message.data,
                    sequence=message.sequence,
                )
                kept += 1
        except InvalidMagic:
            sink.close()
            target.unlink()
            raise LogError(f"not an MCAP file: {path}") from None
        except Exception:  # the cut: everything before it was copied
            pass
        writer.finish()
        chunk_indexes.close()
    if output is None:
        os.replace(target, path)
    return kept


def _copy_channel(
    writer: Writer, schema: Schema | None, channel: Channel, schemas: dict[int, int]
) -> int:
    schema_id = 0
    if schema is not None:
        if schema.id not in schemas:
            schemas[schema.id] = writer.register_schema(
                name=schema.name, encoding=schema.encoding, data=schema.data
            )
        schema_id = schemas[schema.id]
    return writer.register_channel(
        topic=channel.topic,
        message_encoding=channel.message_encoding,
        schema_id=schema_id,
        metadata=dict(channel.metadata),
    )
