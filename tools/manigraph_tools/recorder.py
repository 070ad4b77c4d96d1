"""``manigraph record``: every sample under ``manigraph/**`` into MCAP files.

The Zenoh callback only appends to a bounded queue, so a slow disk never slows a publisher; a
writer thread drains the queue and flushes at least every 100 ms, so ``kill -9`` loses at most
the last 100 ms of samples. What the recorder can cost is bounded too:

* **files rotate** by size (``max_bytes``) and age (``max_seconds``): the current file is
  finalised and the next one opened (``run.mcap``, ``run.001.mcap``, ...; in a directory, a new
  timestamped name);
* **the queue holds at most** ``MAX_QUEUED_BYTES`` of samples waiting for the disk; past that,
  arriving samples are dropped, counted and reported (an error ``ServiceStatus``, once a second);
* a file whose recorder was killed is finalised by ``manigraph record --recover FILE``, and a
  recorder writing into a directory finalises the unfinished files it finds there at start-up.

Beside the JSON channels (one per key, byte for byte what was on the bus), the writer thread
also writes Foxglove's well-known types, ``/foxglove/scene`` and ``/foxglove/tf``
(:mod:`manigraph_tools.foxglove_bridge`), so the log opens in Foxglove's 3D panel as it is.

Robot cells (:mod:`manigraph_shared.cells`): a recorder in the default cell records every
cell, each on its own channels (the key is the topic: ``manigraph/cell-1/world/scene``), and
draws each cell apart (``/cell-1/foxglove/scene``); ``--cell NAME`` records that cell only.
"""

from __future__ import annotations

import queue
import threading
import time
from datetime import datetime
from pathlib import Path

import zenoh

from manigraph_shared.bus import ALIVE_PREFIX, Bus
from manigraph_shared.cells import cell_of, default_key
from manigraph_shared.errors import ManigraphError
from manigraph_shared.mcap_log import McapLogWriter, is_finalised, recover_log
from manigraph_shared.messages.base import PREFIX
from manigraph_shared.service import TRIM_AFTER_MESSAGES, Service, malloc_trim
from manigraph_tools.foxglove_bridge import FOXGLOVE_SCHEMAS, FoxgloveBridge

DEFAULT_MAX_BYTES = 256 * 1024 * 1024
DEFAULT_MAX_SECONDS = 3600.0
MAX_QUEUED_BYTES = 64 * 1024 * 1024
#: Cells drawn for Foxglove apart (every cell's samples are logged whatever their number).
MAX_DRAWN_CELLS = 64
#: A file in the output directory untouched this long has no live recorder (a live one writes
#: its own heartbeat every second and flushes every 100 ms).
ABANDONED_AFTER_SECONDS = 10.0


def resolve_output(output: Path) -> Path:
    """A directory (existing, or named with a trailing slash) gets a timestamped file."""
    if is_directory(output):
        return output / f"manigraph-{datetime.now().strftime('%Y%m%d-%H%M%S')}.mcap"
    return output


def is_directory(output: Path) -> bool:
    return output.is_dir() or str(output).endswith("/") or not output.suffix


class Recorder(Service):
    name = "recorder"
    tick_period = 1.0  # report dropped samples, trim the heap after bursts

    def __init__(
        self,
        bus: Bus,
        output: Path,
        flush_interval: float = 0.1,
        max_bytes: int = DEFAULT_MAX_BYTES,
        max_seconds: float = DEFAULT_MAX_SECONDS,
        foxglove: bool = True,
    ) -> None:
        super().__init__(bus)
        if max_bytes < 1024:
            raise ManigraphError(f"max_bytes: must be >= 1024, got {max_bytes}")
        if max_seconds <= 0:
            raise ManigraphError(f"max_seconds: must be > 0, got {max_seconds}")
        self.output = output
        self.path = resolve_output(output)
        self.first_path = self.path
        self.flush_interval = flush_interval
        #: The default cell's Foxglove view; every other cell seen gets its own in
        #: ``_cell_views`` (at most ``MAX_DRAWN_CELLS``).
        self._foxglove = FoxgloveBridge() if foxglove else None
        self._cell_views: dict[str, FoxgloveBridge] = {}
        self.max_bytes = max_bytes
        self.max_seconds = max_seconds
        self.files: list[Path] = []
        self._samples: queue.SimpleQueue[tuple[str, bytes, int] | None] = queue.SimpleQueue()
        self._queued_bytes = 0
        self._queue_lock = threading.Lock()
        self._writer_thread = threading.Thread(target=self._write_loop, name="mcap-writer")
        self.samples_seen = 0
        self.samples_dropped = 0
        self._drops_reported = 0
        self._seen_at_trim = 0
        self._trim_when_drained = False
        self.messages_written = 0
        #: Samples the Foxglove view could not draw (each is in the log as it was on the bus).
        self.foxglove_failures = 0
        self._foxglove_failed_keys: set[str] = set()

    def setup(self) -> None:
        if is_directory(self.output) and self.output.is_dir():
            for stale in sorted(self.output.glob("manigraph-*.mcap")):
                if time.time() - stale.stat().st_mtime > ABANDONED_AFTER_SECONDS and not (
                    is_finalised(stale)
                ):
                    kept = recover_log(stale)
                    self.log.info(
                        "finalised %s left by a killed recorder (%d messages)", stale, kept
                    )
        self._open(self.path)
        self._writer_thread.start()
        self.bus.subscribe_raw(f"{PREFIX}/**", self._enqueue)
        self.log.info("recording %s/** to %s", PREFIX, self.path)

    def _open(self, path: Path) -> None:
        self.path = path
        self._log = McapLogWriter(path, self.flush_interval)
        if self._foxglove is not None:
            for topic, schema in FOXGLOVE_SCHEMAS.items():
                self._log.add_channel(topic, "protobuf", schema.name, schema.encoding, schema.data)
        self._opened = time.monotonic()
        self.files.append(path)

    def _next_path(self) -> Path:
        if is_directory(self.output):
            path = resolve_output(self.output)
            stem, n = path.stem, 0
            while path in self.files or path.exists():
                n += 1
                path = path.with_name(f"{stem}-{n}.mcap")
            return path
        first = self.first_path
        return first.with_name(f"{first.stem}.{len(self.files):03d}{first.suffix}")

    def _enqueue(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if key.startswith(ALIVE_PREFIX) or sample.kind != zenoh.SampleKind.PUT:
            return
        self.samples_seen += 1
        data = sample.payload.to_bytes()
        with self._queue_lock:
            if self._queued_bytes + len(data) > MAX_QUEUED_BYTES:
                self.samples_dropped += 1
                return
            self._queued_bytes += len(data)
        self._samples.put((key, data, time.time_ns()))

    def _write_loop(self) -> None:
        while True:
            try:
                item = self._samples.get(timeout=self.flush_interval / 2)
            except queue.Empty:
                self._log.maybe_flush()
                self._maybe_rotate()
                continue
            if item is None:
                break
            with self._queue_lock:
                self._queued_bytes -= len(item[1])
            self._log.write(*item)
            if self._foxglove is not None:
                self._write_foxglove(self._foxglove, *item)
            self.messages_written += 1
            self._maybe_rotate()
        self._log.close()

    def _write_foxglove(
        self, default_view: FoxgloveBridge, key: str, data: bytes, log_time_ns: int
    ) -> None:
        """The sample's Foxglove view, if it has one, drawn in its cell's view. One the view
        cannot draw costs only the view: the sample is already written, the writer goes on,
        and the first failure per key is logged with its traceback."""
        cell = cell_of(key)
        bridge = default_view if cell is None else self._cell_views.get(cell)
        if bridge is None:
            if len(self._cell_views) >= MAX_DRAWN_CELLS:  # forged cell names cannot grow this
                return
            bridge = self._cell_views[str(cell)] = FoxgloveBridge()
        try:
            converted = list(bridge.convert(default_key(key), data))
        except Exception:
            self.foxglove_failures += 1
            if key not in self._foxglove_failed_keys:
                self._foxglove_failed_keys.add(key)
                self.log.exception("cannot draw %s for Foxglove (the sample is logged)", key)
            return
        for item in converted:
            topic = item.topic if cell is None else f"/{cell}{item.topic}"
            if cell is not None:
                schema = FOXGLOVE_SCHEMAS[item.topic]
                self._log.add_channel(topic, "protobuf", schema.name, schema.encoding, schema.data)
            self._log.write(topic, item.message.encode(), log_time_ns)

    def trim_heap(self) -> bool:
        """Give freed heap back to the OS (glibc keeps it) during a burst, and once more when
        the samples it queued have been written: a trim while the queue still holds up to
        ``MAX_QUEUED_BYTES`` frees little, and heartbeats alone take minutes to count as the
        next burst (a 30 s scene flood left the recorder 30 % larger a minute later)."""
        burst = self.samples_seen - self._seen_at_trim >= TRIM_AFTER_MESSAGES
        drained = self._trim_when_drained and self._samples.empty()
        if not (burst or drained):
            return False
        self._trim_when_drained = burst
        self._seen_at_trim = self.samples_seen
        malloc_trim()
        return True

    def _maybe_rotate(self) -> None:
        too_big = self._log.size >= self.max_bytes
        if too_big or time.monotonic() - self._opened >= self.max_seconds:
            self._log.close()
            previous = self.path
            self._open(self._next_path())
            self.log.info(
                "rotated %s (%s) -> %s", previous, "size" if too_big else "age", self.path
            )

    def tick(self) -> None:
        self.trim_heap()
        dropped = self.samples_dropped
        if dropped > self._drops_reported:
            self._drops_reported = dropped
            self.report_error(
                ManigraphError(
                    f"recorder behind the bus: {dropped} samples dropped "
                    f"({MAX_QUEUED_BYTES >> 20} MiB waiting for the disk)"
                )
            )

    def teardown(self) -> None:
        self._samples.put(None)
        self._writer_thread.join(timeout=10)
        self.log.info(
            "wrote %d messages to %s", self.messages_written, ", ".join(map(str, self.files))
        )
