"""A bounded chunk index for the ``mcap`` writer: kept on disk, not in memory, until the summary.

The ``mcap`` package's ``Writer`` keeps one ``ChunkIndex`` per chunk in a list until ``finish``
writes them into the file's summary. A recorder closes a chunk every 100 ms (so that a
``kill -9`` loses at most that much), so the list grows ~0.6-0.9 KiB a chunk, ~8 KiB/s, for as
long as the file is open (up to an hour: ~30 MiB). None of the writer's options avoids it:
``index_types`` without ``CHUNK`` leaves the indexes out of the summary (readers then scan the
whole file) but the writer appends them to the list all the same, and larger chunks would lose
more on a kill.

:class:`SpilledChunkIndexes` takes the list's place: each index the writer appends is written
at once, as its MCAP record, to an unnamed temporary file beside the log, and read back one by
one when ``finish`` writes the summary. The file is the same as before, byte for byte: every
reader (``read_log``, ``mcap.reader.make_reader`` and its summary, Foxglove) opens it, seeking
by the chunk indexes as it did. What stays in memory is a counter.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from mcap.data_stream import ReadDataStream, RecordBuilder
from mcap.opcode import Opcode
from mcap.records import ChunkIndex
from mcap.writer import Writer

#: Where ``mcap.writer.Writer`` (1.x) keeps its chunk indexes (a name-mangled private list).
_WRITER_CHUNK_INDEXES = "_Writer__chunk_indices"


class SpilledChunkIndexes:
    """The writer's list of chunk indexes, on disk: ``append`` and iteration, nothing else."""

    def __init__(self, directory: Path) -> None:
        # Open as long as the writer is (closed by close()); unnamed, so nothing is left.
        self._file = tempfile.TemporaryFile(dir=directory, prefix=".mcap-index-")  # noqa: SIM115
        self._count = 0

    def append(self, index: ChunkIndex) -> None:
        record = RecordBuilder()
        index.write(record)
        self._file.write(record.end())
        self._count += 1

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[ChunkIndex]:
        """Every index appended, in order (the writer's ``finish`` iterates once)."""
        self._file.flush()
        self._file.seek(0)
        stream = ReadDataStream(self._file)
        try:
            for _ in range(self._count):
                opcode, _length = stream.read1(), stream.read8()
                if opcode != Opcode.CHUNK_INDEX:
                    raise ValueError(f"chunk index spill: record {opcode:#x} is no chunk index")
                yield ChunkIndex.read(stream)
        finally:
            self._file.seek(0, os.SEEK_END)

    def close(self) -> None:
        self._file.close()


def bound_chunk_indexes(writer: Writer, directory: Path) -> SpilledChunkIndexes:
    """Make ``writer`` (not yet started) keep its chunk indexes in a :class:`SpilledChunkIndexes`
    in ``directory``; close it after ``writer.finish()``. Refuses a writer that does not keep
    them where ``mcap`` 1.x does (another version of the package): the test of this module
    fails then, rather than the recorder's memory growing again unnoticed."""
    kept = getattr(writer, _WRITER_CHUNK_INDEXES, None)
    if not isinstance(kept, list) or kept:
        raise TypeError(
            f"mcap.writer.Writer keeps no empty list {_WRITER_CHUNK_INDEXES}: this mcap "
            "version is not the one manigraph_shared.mcap_index was written for"
        )
    spill = SpilledChunkIndexes(directory)
    setattr(writer, _WRITER_CHUNK_INDEXES, spill)
    return spill
