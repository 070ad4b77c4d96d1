"""Memory the MCAP writer holds per chunk until the file closes: the ``mcap`` package's
``Writer`` as it is, against ``McapLogWriter`` (its chunk indexes spilled to disk,
``manigraph_shared.mcap_index``).

Each chunk holds one small message on each of ``--channels`` channels and is closed by a
flush, as the recorder closes one every 100 ms. The Python heap (``tracemalloc``) is read
after ``--chunks`` chunks, before ``finish``; the figure is its growth divided by the chunks.

    python bench/bench_mcap_index.py                          # 20,000 chunks, 1 and 8 channels
    python bench/bench_mcap_index.py --chunks 5000 --channels 8
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import tracemalloc
from pathlib import Path

from mcap.writer import CompressionType, Writer

from manigraph_shared.mcap_log import McapLogWriter, read_log

PAYLOAD = b'{"service":"sim","state":"ok","stamp":1.0}'


def plain_writer(path: Path, chunks: int, channels: int) -> float:
    """Heap bytes per chunk held by ``mcap.writer.Writer`` itself."""
    with path.open("wb") as stream:
        writer = Writer(stream, compression=CompressionType.ZSTD)
        writer.start(profile="bench")
        schema = writer.register_schema("s", "jsonschema", b"{}")
        ids = [writer.register_channel(f"c/{n}", "json", schema) for n in range(channels)]
        tracemalloc.start()
        before = tracemalloc.get_traced_memory()[0]
        for chunk in range(chunks):
            for channel in ids:
                writer.add_message(channel, chunk, PAYLOAD, chunk)
            writer.flush()
        grown = tracemalloc.get_traced_memory()[0] - before
        tracemalloc.stop()
        writer.finish()
    return grown / chunks


def log_writer(path: Path, chunks: int, channels: int) -> float:
    """Heap bytes per chunk held by ``McapLogWriter`` (indexes on disk)."""
    log = McapLogWriter(path, flush_interval=3600.0)
    topics = [f"manigraph/bench/{n}" for n in range(channels)]
    for topic in topics:  # channels registered before the measurement, as above
        log.write(topic, PAYLOAD, 0)
    log.flush()
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    for chunk in range(chunks):
        for topic in topics:
            log.write(topic, PAYLOAD, chunk)
        log.flush()
    grown = tracemalloc.get_traced_memory()[0] - before
    tracemalloc.stop()
    log.close()
    read = sum(1 for _ in read_log(path))
    assert read == (chunks + 1) * channels, f"read {read} messages back"
    return grown / chunks


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("--chunks", type=int, default=20_000)
    parser.add_argument("--channels", type=int, nargs="+", default=[1, 8])
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for channels in args.channels:
            for name, run in (("mcap Writer", plain_writer), ("McapLogWriter", log_writer)):
                started = time.perf_counter()
                per_chunk = run(Path(tmp) / f"{name[:4]}-{channels}.mcap", args.chunks, channels)
                rows.append(
                    {
                        "writer": name,
                        "channels": channels,
                        "chunks": args.chunks,
                        "bytes_per_chunk": round(per_chunk, 1),
                        "seconds": round(time.perf_counter() - started, 1),
                    }
                )
                print(
                    f"{name:14s} {channels} channel(s): {per_chunk:7.1f} bytes a chunk held "
                    f"({args.chunks} chunks)",
                    flush=True,
                )
    print(json.dumps({"bench": "mcap_index", "rows": rows}))


if __name__ == "__main__":
    main()
