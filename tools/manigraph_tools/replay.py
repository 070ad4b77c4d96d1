"""``manigraph replay``: publish a recorded log back onto the bus with its original timing.

A log can stand in for the sim or a camera. With ``expect_actions`` the recorded planner
decisions are withheld and the live planner's decisions are compared with them instead: the
regression check that guards a policy.

Zenoh delivers samples of different keys on different threads, so a log replayed faster than
it was recorded can reach a subscriber out of order. The check therefore replays in lockstep:
at each withheld decision it waits for the live planner's decision before publishing anything
recorded after it, which keeps the causal order the live system had.
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
from manigraph_shared.messages import Action, Delivery, key_matches
from manigraph_shared.messages.base import PREFIX


@dataclass
class ActionCheck:
    """Recorded decisions against the live planner's, by decision id."""

    expected: dict[str, Action] = field(default_factory=dict)
    received: dict[str, Action] = field(default_factory=dict)
    _arrived: threading.Condition = field(default_factory=threading.Condition)

    def receive(self, action: Action) -> None:
        with self._arrived:
            self.received[action.decision_id] = action
            self._arrived.notify_all()

    def wait_for(self, decision_id: str, timeout: float) -> bool:
        with self._arrived:
            return self._arrived.wait_for(lambda: decision_id in self.received, timeout)

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
        withhold: Iterable[str] = (),
    ) -> None:
        if speed <= 0:
            raise LogError("speed must be > 0")
        self.bus = bus
        self.speed = speed
        self.withhold = list(withhold)
        # Only the bus's own keys go back on the bus: the log's Foxglove channels
        # (/foxglove/...) are drawings of them, not messages of the contract.
        selected = read_log(path, list(topics) or [f"{PREFIX}/**"], exclude)
        self.messages = sorted(selected, key=lambda item: item.log_time_ns)
        if not self.messages:
            raise LogError(f"{path} holds no messages matching the filter")

    def play(
        self,
        stop: threading.Event | None = None,
        on_withheld: Callable[[LoggedMessage], None] | None = None,
    ) -> int:
        """Publish every message once, keeping the recorded gaps (scaled by ``speed``).

        Messages under a ``withhold`` pattern are not published but handed to ``on_withheld``,
        which may block; the schedule resumes from where it returns.
        """
        stop = stop or threading.Event()
        start_wall = time.monotonic()
        start_log = self.messages[0].log_time_ns
        for index, item in enumerate(self.messages):
            due = start_wall + (item.log_time_ns - start_log) / 1e9 / self.speed
            if stop.wait(max(0.0, due - time.monotonic())):
                return index
            if any(key_matches(pattern, item.topic) for pattern in self.withhold):
                waited = time.monotonic()
                if on_withheld is not None:
                    on_withheld(item)
                start_wall += time.monotonic() - waited
                continue
            # Everything BLOCK: a log replayed as a regression check must lose nothing, even
            # the scenes that were DROP-able live.
            self.bus.put_raw(item.topic, item.data, Delivery.RELIABLE)
        return len(self.messages)


def recorded_actions(path: Path) -> dict[str, Action]:
    actions: dict[str, Action] = {}
    for item in read_log(path, [Action.key]):
        action = Action.decode(item.data, item.topic)
        actions[action.decision_id] = action
    return actions
