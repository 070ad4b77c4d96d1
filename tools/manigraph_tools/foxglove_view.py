"""``manigraph view``: the live bus in Foxglove, over Foxglove's WebSocket protocol.

A foxglove-sdk WebSocket server (``ws://127.0.0.1:8765`` by default) serves

* every ``manigraph/**`` key as a JSON channel with its JSON Schema (as in a recorded log);
* ``/foxglove/scene`` and ``/foxglove/tf``, the well-known types Foxglove's 3D panel draws
  (:mod:`manigraph_tools.foxglove_bridge`).

Robot cells (:mod:`manigraph_shared.cells`), as the recorder writes them: a cell's key is its
channel (``manigraph/cell-1/world/scene``, with the ``Scene`` schema) and each cell is drawn
apart, on ``/cell-1/foxglove/scene`` and ``/cell-1/foxglove/tf`` (at most
``MAX_DRAWN_CELLS`` cells). A view in the default cell shows every cell; ``--cell NAME``, that
cell only. A log recorded from cells replays into the view the same way.

Connect with Foxglove (app or web): Open connection → Foxglove WebSocket → the URL. The Zenoh
callback only queues samples (at most ``MAX_PENDING``; beyond that they are dropped and
counted; at most ``MAX_CHANNELS`` keys are served), and one thread converts and logs them, so
a slow viewer never slows the bus. The latest scene and transforms are sent again every
second, so a viewer that connects between two scenes sees the picture at once.
"""

from __future__ import annotations

import queue
import threading
import time
from typing import ClassVar

import foxglove
import zenoh
from foxglove import Channel, Schema
from foxglove.channels import FrameTransformsChannel, SceneUpdateChannel

from manigraph_shared.bus import ALIVE_PREFIX, Bus
from manigraph_shared.cells import cell_of, default_key
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import message_type_for_key
from manigraph_shared.messages.base import MAX_PAYLOAD_BYTES, PREFIX
from manigraph_shared.service import Service
from manigraph_tools.foxglove_bridge import SCENE_TOPIC, TF_TOPIC, Converted, FoxgloveBridge

MAX_PENDING = 4096
#: Keys served as channels; a publisher inventing keys cannot grow the view without bound.
MAX_CHANNELS = 512
#: Cells drawn apart; a publisher inventing cell names cannot grow the view without bound.
MAX_DRAWN_CELLS = 64
RESEND_SECONDS = 1.0
DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765


class FoxgloveView(Service):
    name: ClassVar[str] = "view"

    def __init__(self, bus: Bus, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT) -> None:
        super().__init__(bus)
        self.host = host
        self.port = port
        #: One bridge per cell drawn (``None``: the default cell), each keeping its own scene.
        self.bridges: dict[str | None, FoxgloveBridge] = {None: FoxgloveBridge()}
        self.samples_dropped = 0
        self._pending: queue.Queue[tuple[str, bytes] | None] = queue.Queue(maxsize=MAX_PENDING)
        self._raw: dict[str, Channel] = {}
        self._last: dict[str, Converted] = {}
        self._drawn: dict[str, SceneUpdateChannel | FrameTransformsChannel] = {}
        self._worker = threading.Thread(target=self._convert_loop, name="foxglove-view")

    def setup(self) -> None:
        try:
            self.server = foxglove.start_server(name="manigraph", host=self.host, port=self.port)
        except Exception as exc:  # the SDK raises its own error types for a busy port
            raise ConfigError("port", f"cannot serve on {self.host}:{self.port}: {exc}") from None
        self._drawn[SCENE_TOPIC] = SceneUpdateChannel(SCENE_TOPIC)
        self._drawn[TF_TOPIC] = FrameTransformsChannel(TF_TOPIC)
        self._worker.start()
        self.bus.subscribe_raw(f"{PREFIX}/**", self._enqueue)
        self.log.info("serving the bus to Foxglove at ws://%s:%d", self.host, self.server.port)

    def _enqueue(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if key.startswith(ALIVE_PREFIX) or sample.kind != zenoh.SampleKind.PUT:
            return
        try:
            self._pending.put_nowait((key, sample.payload.to_bytes()))
        except queue.Full:
            self.samples_dropped += 1

    def _convert_loop(self) -> None:
        next_resend = time.monotonic() + RESEND_SECONDS
        while True:
            try:
                item = self._pending.get(timeout=RESEND_SECONDS / 4)
            except queue.Empty:
                item = ()  # type: ignore[assignment]
            if item is None:
                return
            try:
                if item:
                    self._forward(*item)
                if time.monotonic() >= next_resend:
                    next_resend = time.monotonic() + RESEND_SECONDS
                    for converted in self._last.values():
                        self._log(converted)
            except Exception:  # one bad sample must not stop the view
                self.log.exception("cannot forward a sample to Foxglove")

    def _forward(self, key: str, payload: bytes) -> None:
        if len(payload) > MAX_PAYLOAD_BYTES:
            self.samples_dropped += 1
            return
        channel = self._raw_channel(key)
        if channel is None:
            self.samples_dropped += 1
            return
        channel.log(payload, log_time=time.time_ns())
        cell = cell_of(key)
        bridge = self.bridges.get(cell)
        if bridge is None:
            if len(self.bridges) > MAX_DRAWN_CELLS:
                return
            bridge = self.bridges[cell] = FoxgloveBridge()
        for converted in bridge.convert(default_key(key), payload):
            if cell is not None:
                converted = Converted(f"/{cell}{converted.topic}", converted.message)
            self._last[converted.topic] = converted
            self._log(converted)

    def _raw_channel(self, key: str) -> Channel | None:
        channel = self._raw.get(key)
        if channel is None:
            if len(self._raw) >= MAX_CHANNELS:
                return None
            message_type = message_type_for_key(default_key(key))
            schema = (
                Schema(
                    name=message_type.type_name(),
                    encoding="jsonschema",
                    data=message_type.mcap_schema(),
                )
                if message_type is not None
                else None
            )
            channel = Channel(key, schema=schema, message_encoding="json")
            self._raw[key] = channel
        return channel

    def _log(self, converted: Converted) -> None:
        channel = self._drawn.get(converted.topic)
        if channel is None:  # a cell's first update: its topic is /<cell>/foxglove/...
            scene = converted.topic.endswith(SCENE_TOPIC)
            channel = (SceneUpdateChannel if scene else FrameTransformsChannel)(converted.topic)
            self._drawn[converted.topic] = channel
        channel.log(converted.message, log_time=time.time_ns())  # type: ignore[arg-type]

    def teardown(self) -> None:
        self._pending.put(None)
        self._worker.join(timeout=5)
        self.server.stop()
        self.log.info(
            "served %d channels; %d samples dropped", len(self._raw), self.samples_dropped
        )
