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
from manigraph_shared.messages import Action, Delivery, ServiceStatus, key_matches
from manigraph_shared.messages.base import PREFIX


@dataclass
class ActionCheck:
    """Recorded decisions against the live planner's, by decision id, in the log's order.

    :meth:`check` compares one withheld decision with the live one as the replay reaches it,
    so the first divergence is known at once (the replay stops there unless it keeps going).
    """

    expected: dict[str, Action] = field(default_factory=dict)
    received: dict[str, Action] = field(default_factory=dict)
    #: ids of the withheld decisions the replay reached, in order
    reached: list[str] = field(default_factory=list)
    #: one line per differing decision, in the order found
    problems: list[str] = field(default_factory=list)
    _arrived: threading.Condition = field(default_factory=threading.Condition)

    def receive(self, action: Action) -> None:
        with self._arrived:
            self.received[action.decision_id] = action
            self._arrived.notify_all()

    def wait_for(self, decision_id: str, timeout: float) -> Action | None:
        """The live decision ``decision_id``, waiting at most ``timeout`` seconds for it."""
        with self._arrived:
            self._arrived.wait_for(lambda: decision_id in self.received, timeout)
            return self.received.get(decision_id)

    def check(self, want: Action, timeout: float) -> str | None:
        """Wait at most ``timeout`` s for the live decision ``want.decision_id``; the
        mismatch line (also kept in :attr:`problems`) or None when it is the same."""
        self.reached.append(want.decision_id)
        got = self.wait_for(want.decision_id, timeout)
        if got is not None and self.signature(got) == self.signature(want):
            return None
        found = "nothing" if got is None else choice(got)
        if got is None:
            found += f" within {timeout:g} s"
        line = f"{name(want)}: recorded {choice(want)}, got {found}"
        self.problems.append(line)
        return line

    def unexpected(self) -> list[str]:
        """Lines for live decisions the log does not hold (meaningful after a full replay)."""
        return [
            f"{name(self.received[d])}: not recorded, got {choice(self.received[d])}"
            for d in sorted(self.received.keys() - self.expected.keys())
        ]

    @staticmethod
    def signature(action: Action) -> tuple[object, ...]:
        return (action.object_id, action.goal_id, action.orientation_index, action.family_action)

    def mismatches(self) -> list[str]:
        """Every problem found so far, then every unexpected live decision."""
        return [*self.problems, *self.unexpected()]


def name(action: Action) -> str:
    """``decision 5 (episode stack-4-...:5)``: its number in the episode, and its id."""
    number = action.decision_id.rpartition(":")[2]
    return f"decision {number} (episode {action.decision_id})"


def choice(action: Action) -> str:
    """``block_2 -> goal_3``, with the orientation and family action when it has them."""
    text = f"{action.object_id} -> {action.goal_id}"
    extras = [
        f"orientation {action.orientation_index}" if action.orientation_index is not None else "",
        f"family action {action.family_action}" if action.family_action is not None else "",
    ]
    extras = [e for e in extras if e]
    return text + (f" ({', '.join(extras)})" if extras else "")


#: Services' statuses: all a log holds while its stack starts up.
STATUSES = ServiceStatus.key.replace("{service}", "*")


class Replayer:
    """Publishes a log's ``manigraph/**`` messages with their recorded gaps.

    Args:
        topics, exclude: key patterns to publish, and to leave out.
        withhold: key patterns handed to ``play``'s ``on_withheld`` instead of published.
        skip_start_up: start at the first message that is not a service's status: a log
            recorded from ``manigraph up --record`` begins with the seconds its stack took to
            start (8.9 s of heartbeats before the first episode in ``tests/golden/``), which a
            regression check need not wait through.
    """

    def __init__(
        self,
        bus: Bus,
        path: Path,
        speed: float = 1.0,
        topics: Iterable[str] = (),
        exclude: Iterable[str] = (),
        withhold: Iterable[str] = (),
        skip_start_up: bool = False,
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
        if skip_start_up:  # the stack's start-up: only services' statuses until the first episode
            first = next(
                (i for i, m in enumerate(self.messages) if not key_matches(STATUSES, m.topic)),
                len(self.messages),
            )
            self.messages = self.messages[first:]
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
