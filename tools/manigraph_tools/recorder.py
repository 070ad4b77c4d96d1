"""``manigraph record``: every sample under ``manigraph/**`` into one MCAP file.

The Zenoh callback only appends to a queue, so a slow disk never slows a publisher; a writer
thread drains the queue and flushes at least every 100 ms, so ``kill -9`` loses at most the
last 100 ms of samples.

Beside the JSON channels (one per key, byte for byte what was on the bus), the writer thread
also writes Foxglove's well-known types, ``/foxglove/scene`` and ``/foxglove/tf``
(:mod:`manigraph_tools.foxglove_bridge`), so the log opens in Foxglove's 3D panel as it is.
"""

from __future__ import annotations

import queue
import threading
import time
from datetime import datetime
from pathlib import Path

import zenoh

from manigraph_shared.bus import ALIVE_PREFIX, Bus
from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages.base import PREFIX
from manigraph_shared.service import Service
from manigraph_tools.foxglove_bridge import FOXGLOVE_SCHEMAS, FoxgloveBridge


def resolve_output(output: Path) -> Path:
    """A directory (existing, or named with a trailing slash) gets a timestamped file."""
    if output.is_dir() or str(output).endswith("/") or not output.suffix:
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
        return output / f"manigraph-{stamp}.mcap"
    return output


class Recorder(Service):
    name = "recorder"

    def __init__(
        self, bus: Bus, output: Path, flush_interval: float = 0.1, foxglove: bool = True
    ) -> None:
        super().__init__(bus)
        self.path = resolve_output(output)
        self.flush_interval = flush_interval
        self._foxglove = FoxgloveBridge() if foxglove else None
        self._samples: queue.SimpleQueue[tuple[str, bytes, int] | None] = queue.SimpleQueue()
        self._writer_thread = threading.Thread(target=self._write_loop, name="mcap-writer")
        self.samples_seen = 0

    def setup(self) -> None:
        self._log = McapLogWriter(self.path, self.flush_interval)
        if self._foxglove is not None:
            for topic, schema in FOXGLOVE_SCHEMAS.items():
                self._log.add_channel(topic, "protobuf", schema.name, schema.encoding, schema.data)
        self._writer_thread.start()
        self.bus.subscribe_raw(f"{PREFIX}/**", self._enqueue)
        self.log.info("recording %s/** to %s", PREFIX, self.path)

    def _enqueue(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if key.startswith(ALIVE_PREFIX) or sample.kind != zenoh.SampleKind.PUT:
            return
        self.samples_seen += 1
        self._samples.put((key, sample.payload.to_bytes(), time.time_ns()))

    def _write_loop(self) -> None:
        while True:
            try:
                item = self._samples.get(timeout=self.flush_interval / 2)
            except queue.Empty:
                self._log.maybe_flush()
                continue
            if item is None:
                break
            self._log.write(*item)
            if self._foxglove is not None:
                key, data, log_time_ns = item
                for converted in self._foxglove.convert(key, data):
                    self._log.write(converted.topic, converted.message.encode(), log_time_ns)
        self._log.close()

    def teardown(self) -> None:
        self._samples.put(None)
        self._writer_thread.join(timeout=10)
        self.log.info("wrote %d messages to %s", self._log.messages_written, self.path)
