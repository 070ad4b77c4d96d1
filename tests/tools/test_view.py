"""`manigraph view` as a user runs it: a real router, the view process, a Foxglove WebSocket
client speaking foxglove.websocket.v1."""

from __future__ import annotations

import base64
import json
import struct
import time
from collections.abc import Callable
from typing import Any

import pytest
from websockets.sync.client import ClientConnection, connect

from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneGoal, SceneObject
from manigraph_shared.messages import Vector3 as V
from manigraph_testkit.testing import Stack, free_port
from manigraph_tools.foxglove_bridge import SCENE_TOPIC

ProtobufDecoder = Callable[[str, bytes, bytes], dict[str, Any]]
#: foxglove-sdk 0.30 names the Foxglove WebSocket protocol (foxglove.websocket.v1) so; the
#: frames are those of foxglove.websocket.v1.
SUBPROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 0x01
#: The status foxglove-sdk sends for a subscription to a channel it does not (yet) know.
UNKNOWN_CHANNEL = "Unknown channel ID: "

pytestmark = pytest.mark.integration


def a_scene() -> Scene:
    return Scene(
        episode_id="view-1",
        stamp=time.time(),
        sequence=3,
        objects=[
            SceneObject(
                id="block_0",
                category=ObjectCategory.BLOCK,
                position=V(x=0.42, y=-0.13, z=0.02),
                size=V(x=0.04, y=0.04, z=0.04),
            )
        ],
        goals=[
            SceneGoal(id="goal_0", category=GoalCategory.BLOCK, position=V(x=0.3, y=0.2, z=0.02))
        ],
    )


class FoxgloveClient:
    """The client side of the protocol that the test needs: advertisements and data frames."""

    def __init__(self, ws: ClientConnection, timeout: float = 20.0) -> None:
        self.ws = ws
        self.deadline = time.monotonic() + timeout
        self.channels: dict[str, dict[str, Any]] = {}
        self.data: dict[int, list[bytes]] = {}
        #: Subscription id -> channel id, as sent.
        self.subscribed: dict[int, int] = {}

    def _read(self, until: float | None = None) -> None:
        """One frame, waiting until ``until`` (at most the deadline; TimeoutError after)."""
        end = self.deadline if until is None else min(until, self.deadline)
        frame = self.ws.recv(timeout=max(0.01, end - time.monotonic()))
        if isinstance(frame, str):
            message = json.loads(frame)
            if message["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in message["channels"]})
            elif message["op"] == "status" and message["message"].startswith(UNKNOWN_CHANNEL):
                self._subscribe_again(int(message["message"].removeprefix(UNKNOWN_CHANNEL)))
        elif frame[0] == MESSAGE_DATA:
            subscription, _log_time = struct.unpack_from("<IQ", frame, 1)
            self.data.setdefault(subscription, []).append(frame[13:])

    def channel(self, topic: str) -> dict[str, Any]:
        while topic not in self.channels:
            self._read()
        return self.channels[topic]

    def subscribe(self, subscription: int, topic: str) -> None:
        channel_id = self.channel(topic)["id"]
        self.subscribed[subscription] = channel_id
        subscriptions = [{"id": subscription, "channelId": channel_id}]
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def _subscribe_again(self, channel_id: int) -> None:
        """foxglove-sdk 0.30 advertises a channel made while a client is connected a moment
        before it can be subscribed to: a subscription sent at once can be refused with
        "Unknown channel ID" (seen under load, for a cell's channel made at its first scene).
        The client then sends it again."""
        for subscription, channel in self.subscribed.items():
            if channel == channel_id:
                subscriptions = [{"id": subscription, "channelId": channel_id}]
                self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def data_of(self, subscription: int, publish: Callable[[], None], every: float = 0.5) -> bytes:
        """The first frame of ``subscription``, calling ``publish`` again every ``every``
        seconds until one comes. A subscription reaches the server some time after it is
        sent, and a sample published before that is not forwarded to it: once, under load,
        the only scene went out first and the frame never came. A live stream publishes
        again anyway."""
        while not self.data.get(subscription):
            publish()
            until = time.monotonic() + every
            while not self.data.get(subscription) and time.monotonic() < until:
                try:
                    self._read(until)
                except TimeoutError:
                    if time.monotonic() >= self.deadline:
                        raise
        return self.data[subscription].pop(0)


def test_a_foxglove_client_receives_the_scene_as_a_scene_update(
    running_stack: Stack, decode_protobuf: ProtobufDecoder
) -> None:
    port = free_port()
    running_stack.start("router")
    running_stack.start("view", "view", "--ws-port", str(port))
    scene = a_scene()
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "view")
        with connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL]) as ws:  # type: ignore[list-item]
            assert ws.subprotocol == SUBPROTOCOL
            client = FoxgloveClient(ws)
            channel = client.channel(SCENE_TOPIC)
            assert (channel["encoding"], channel["schemaName"]) == (
                "protobuf",
                "foxglove.SceneUpdate",
            )
            client.subscribe(7, SCENE_TOPIC)
            schema = base64.b64decode(channel["schema"])
            frame = client.data_of(7, lambda: bus.publish(scene))
            update = decode_protobuf(channel["schemaName"], schema, frame)
            entities = {entity["id"]: entity for entity in update["entities"]}
            block = entities["object/block_0"]["cubes"][0]["pose"]["position"]
            assert (block["x"], block["y"], block["z"]) == pytest.approx((0.42, -0.13, 0.02))
            assert "goal/goal_0" in entities

            # The contract's own channel: JSON with its JSON Schema, the bytes from the bus.
            raw = client.channel(Scene.key)
            assert (raw["encoding"], raw["schemaName"]) == ("json", "manigraph.Scene")
            client.subscribe(8, Scene.key)
            assert Scene.decode(client.data_of(8, lambda: bus.publish(scene))) == scene
    assert running_stack.stop("view") == 0
    assert "served" in running_stack.log("view")


def test_a_cells_scene_has_its_schema_and_is_drawn_on_the_cells_own_topic(
    running_stack: Stack, decode_protobuf: ProtobufDecoder
) -> None:
    """A view in the default cell serves every cell: cell ``left``'s key is its channel, with
    the contract schema, and its scene is drawn apart on ``/left/foxglove/scene``."""
    port = free_port()
    running_stack.start("router")
    running_stack.start("view", "view", "--ws-port", str(port))
    scene = a_scene()
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "view")
        left = bus.in_cell("left")
        with connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL]) as ws:  # type: ignore[list-item]
            client = FoxgloveClient(ws)
            left.publish(scene)
            raw = client.channel("manigraph/left/world/scene")
            assert (raw["encoding"], raw["schemaName"]) == ("json", "manigraph.Scene")
            topic = f"/left{SCENE_TOPIC}"
            channel = client.channel(topic)
            assert channel["schemaName"] == "foxglove.SceneUpdate"
            client.subscribe(9, topic)
            schema = base64.b64decode(channel["schema"])
            frame = client.data_of(9, lambda: left.publish(scene))
            update = decode_protobuf(channel["schemaName"], schema, frame)
            assert "object/block_0" in {entity["id"] for entity in update["entities"]}
        left.close()
    assert running_stack.stop("view") == 0
