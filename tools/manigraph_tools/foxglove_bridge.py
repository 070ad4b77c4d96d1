"""Bus samples in, Foxglove well-known messages out: what the recorder writes beside the JSON
channels and what ``manigraph view`` serves live.

* ``/foxglove/scene`` (``foxglove.SceneUpdate``): the latest ``Scene`` with the episode's latest
  decision and explanation, and an engaged emergency stop in words
  (:mod:`manigraph_tools.foxglove_scene`), on every ``Scene``, ``Action``, ``Explanation`` or
  ``EmergencyStop``;
* ``/foxglove/tf`` (``foxglove.FrameTransforms``): the robot base in the scene frame on the
  first ``Scene``, and every link of the Panda on every ``JointState``
  (:mod:`manigraph_tools.panda_frames`).

A sample that does not validate is skipped (the services already report such samples).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Protocol

from foxglove import Schema
from foxglove.messages import FrameTransforms, SceneUpdate

from manigraph_shared.errors import MessageError
from manigraph_shared.messages import (
    Action,
    EmergencyStop,
    Explanation,
    JointState,
    Message,
    Scene,
    message_type_for_key,
)
from manigraph_tools.foxglove_scene import scene_update
from manigraph_tools.panda_frames import base_transforms, is_panda, robot_transforms

log = logging.getLogger(__name__)

SCENE_TOPIC = "/foxglove/scene"
TF_TOPIC = "/foxglove/tf"
#: Each topic's schema (protobuf, from foxglove-sdk); messages are their ``encode()``.
FOXGLOVE_SCHEMAS: dict[str, Schema] = {
    SCENE_TOPIC: SceneUpdate.get_schema(),
    TF_TOPIC: FrameTransforms.get_schema(),
}
#: The contract types that change what is drawn.
DRAWN = (Scene, Action, Explanation, JointState, EmergencyStop)


class FoxgloveMessage(Protocol):
    """What foxglove-sdk's message classes offer: protobuf bytes and their schema."""

    def encode(self) -> bytes: ...


@dataclass(frozen=True)
class Converted:
    topic: str
    message: FoxgloveMessage


class FoxgloveBridge:
    """Keeps the latest scene, decision and explanation; turns each sample into the updates
    it causes."""

    def __init__(self) -> None:
        self.scene: Scene | None = None
        self.action: Action | None = None
        self.explanation: Explanation | None = None
        #: The latest emergency stop or release heard.
        self.estop: EmergencyStop | None = None
        self._base_sent = False
        self.rejected = 0

    def convert(self, key: str, payload: bytes) -> list[Converted]:
        message_type = message_type_for_key(key)
        if message_type not in DRAWN:
            return []
        assert message_type is not None
        try:
            message = message_type.decode(payload, key)
        except MessageError as exc:
            self.rejected += 1
            log.debug("not drawn: %s", exc)
            return []
        return self.on_message(message)

    def on_message(self, message: Message) -> list[Converted]:
        out: list[Converted] = []
        if isinstance(message, JointState):
            if is_panda(message):
                frame = self.scene.frame_id if self.scene is not None else "world"
                out.append(Converted(TF_TOPIC, robot_transforms(message, frame)))
            return out
        if isinstance(message, Scene):
            self.scene = message
            if not self._base_sent:
                self._base_sent = True
                out.append(Converted(TF_TOPIC, base_transforms(message.frame_id, message.stamp)))
        elif isinstance(message, Action):
            self.action = message
        elif isinstance(message, Explanation):
            self.explanation = message
        elif isinstance(message, EmergencyStop):
            self.estop = message
        update = self.update()
        if update is not None:
            out.insert(0, Converted(SCENE_TOPIC, update))
        return out

    def update(self) -> FoxgloveMessage | None:
        """The picture now, or None before the first scene."""
        if self.scene is None:
            return None
        return scene_update(self.scene, self.action, self._current_explanation(), self.estop)

    def _current_explanation(self) -> Explanation | None:
        """An explanation of an older decision than the latest one is not shown."""
        explanation = self.explanation
        if explanation is None or explanation.decision_id is None or self.action is None:
            return explanation
        return explanation if explanation.decision_id == self.action.decision_id else None
