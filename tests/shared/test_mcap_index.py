"""The MCAP writer's chunk index is bounded: kept on disk until the summary, the file unchanged."""

from __future__ import annotations

import io
import tracemalloc
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from manigraph_shared.mcap_index import bound_chunk_indexes
from manigraph_shared.mcap_log import McapLogWriter, read_log, recover_log

PAYLOAD = b'{"service":"sim","state":"ok","stamp":1.0}'
TOPICS = [f"manigraph/status/s{n}" for n in range(8)]


def write_chunks(log: McapLogWriter, chunks: int, first: int = 0) -> None:
    for chunk in range(first, first + chunks):
        for topic in TOPICS:
            log.write(topic, PAYLOAD, chunk)
        log.flush()  # one chunk, as the recorder closes one every 100 ms


def heap_per_chunk(write: object, chunks: int) -> float:
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        write(chunks)  # type: ignore[operator]
        return (tracemalloc.get_traced_memory()[0] - before) / chunks
    finally:
        tracemalloc.stop()


def test_a_log_writer_holds_no_memory_per_chunk_while_the_file_is_open(tmp_path: Path) -> None:
    log = McapLogWriter(tmp_path / "bounded.mcap", flush_interval=3600.0)
    write_chunks(log, 10)  # channels and schemas registered first
    bounded = heap_per_chunk(lambda n: write_chunks(log, n, first=10), 3000)
    log.close()

    with (tmp_path / "plain.mcap").open("wb") as stream:  # the mcap writer as it is
        writer = Writer(stream, compression=CompressionType.ZSTD)
        writer.start()
        channels = [writer.register_channel(t, "json", 0) for t in TOPICS]

        def plain(chunks: int) -> None:
            for chunk in range(chunks):
                for channel in channels:
                    writer.add_message(channel, chunk, PAYLOAD, chunk)
                writer.flush()

        unbounded = heap_per_chunk(plain, 3000)
        writer.finish()
    assert unbounded > 500  # ~0.9 KiB of ChunkIndex per chunk with 8 channels
    assert bounded < 20, f"{bounded:.0f} bytes held per chunk"


def test_the_file_is_byte_for_byte_the_one_the_mcap_writer_writes(tmp_path: Path) -> None:
    def write(bounded: bool) -> bytes:
        stream = io.BytesIO()
        writer = Writer(stream, compression=CompressionType.ZSTD)
        spill = bound_chunk_indexes(writer, tmp_path) if bounded else None
        writer.start(profile="manigraph", library="test")
        schema = writer.register_schema("s", "jsonschema", b"{}")
        channels = [writer.register_channel(t, "json", schema) for t in TOPICS]
        for chunk in range(50):
            for channel in channels[: 1 + chunk % len(channels)]:
                writer.add_message(channel, chunk, PAYLOAD, chunk, sequence=chunk)
            writer.flush()
        writer.finish()
        if spill is not None:
            assert len(spill) == 50
            spill.close()
        return stream.getvalue()

    assert write(bounded=True) == write(bounded=False)


def test_every_reader_opens_the_file_and_seeks_by_its_chunk_indexes(tmp_path: Path) -> None:
    path = tmp_path / "log.mcap"
    log = McapLogWriter(path, flush_interval=3600.0)
    write_chunks(log, 200)
    log.close()
    assert not list(tmp_path.glob(".mcap-index-*")), "the spill file is left behind"

    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert len(summary.chunk_indexes) == summary.statistics.chunk_count == 200
        times = [message.log_time for _, _, message in reader.iter_messages()]
        late = [m.log_time for _, _, m in reader.iter_messages(starting_at=150)]
    assert times == sorted(times) and len(times) == 200 * len(TOPICS)
    assert late == [t for t in times if t >= 150]  # found through the chunk indexes
    assert sum(1 for _ in read_log(path)) == 200 * len(TOPICS)


def test_a_recovered_file_has_its_chunk_indexes_too(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    log = McapLogWriter(path, flush_interval=3600.0)
    write_chunks(log, 30)  # each chunk flushed; killed here, the file has no summary
    assert recover_log(path) == 30 * len(TOPICS)
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and len(summary.chunk_indexes) >= 1


def test_a_writer_of_another_mcap_version_is_refused_by_name() -> None:
    with pytest.raises(TypeError, match="_Writer__chunk_indices"):
        bound_chunk_indexes(object(), Path("."))  # type: ignore[arg-type]
