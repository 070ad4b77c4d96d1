"""``manigraph replay``: publish a recorded log back onto the bus with its original timing.

A log can stand in for the sim or a camera. With ``expect_actions`` the recorded planner
decisions are withheld and the live planner's decisions are compared with them instead: the
regression check that guards a policy.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.errors import LogError
from manigraph_shared.mcap_log import LoggedMessage, read_log
from manigraph_shared.messages import Action, Delivery, message_type_for_key


@dataclass
class ActionCheck:
    """Recorded decisions against the live planner's, by decision id."""

    expected: dict[str, Action] = field(default_factory=dict)
    received: dict[str, Action] = field(default_factory=dict)

    @staticmethod
    def signature(action: Action) -> tuple[object, ...]:
        return (action.object_id, action.goal_id, action.orientation_index, action.tray_action)

    def mismatches(self) -> list[str]:
        lines = []
        for decision_id, want in self.expected.items():
            got = self.received.get(decision_id)
            if got is None:
                lines.append(f"{decision_id}: expected {self.signature(want)}, got nothing")
            elif self.signature(got) != self.signature(want):
                lines.append(
                    f"{decision_id}: expected {self.signature(want)}, got {self.signature(got)}"
                )
        for decision_id in self.received.keys() - self.expected.keys():
            lines.append(f"{decision_id}: unexpected {self.signature(self.received[decision_id])}")
        return lines


class Replayer:
    def __init__(
        self,
        bus: Bus,
        path: Path,
        speed: float = 1.0,
        topics: Iterable[str] = (),
        exclude: Iterable[str] = (),
    ) -> None:
        if speed <= 0:
            raise LogError("speed must be > 0")
        self.bus = bus
        self.speed = speed
        self.messages = sorted(
            read_log(path, topics, exclude), key=lambda item: item.log_time_ns
        )
        if not self.messages:
            raise LogError(f"{path} holds no messages matching the filter")

    def play(
        self,
        stop: threading.Event | None = None,
        on_progress: Callable[[int, int], None] | None = None,
    ) -> int:
        """Publish every message once, keeping the recorded gaps (scaled by ``speed``)."""
        start_wall = time.monotonic()
        start_log = self.messages[0].log_time_ns
        for index, item in enumerate(self.messages):
            due = start_wall + (item.log_time_ns - start_log) / 1e9 / self.speed
            delay = due - time.monotonic()
            if stop is not None and stop.wait(max(0.0, delay)):
                return index
            if stop is None and delay > 0:
                time.sleep(delay)
            self.bus.put_raw(item.topic, item.data, _delivery(item))
            if on_progress is not None:
                on_progress(index + 1, len(self.messages))
        return len(self.messages)


def _delivery(item: LoggedMessage) -> Delivery:
    message_type = message_type_for_key(item.topic)
    return message_type.delivery if message_type is not None else Delivery.RELIABLE


def recorded_actions(path: Path) -> dict[str, Action]:
    actions: dict[str, Action] = {}
    for item in read_log(path, [Action.key]):
        action = Action.decode(item.data, item.topic)
        actions[action.decision_id] = action
    return actions
