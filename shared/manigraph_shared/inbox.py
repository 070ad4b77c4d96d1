"""A service's bounded inbox: what the bus hands the service thread, with a stated overflow policy.

Every sample a service subscribes to arrives on a Zenoh thread and waits here for the service
thread. The bus is a trust boundary, so a flood must not grow this without bound:

* **state streams** (``Delivery.LATEST``: scenes, joint states) are *coalesced*: at most one
  sample per subscription waits; a newer one replaces it in place (only the newest matters,
  which is what the publisher's congestion control DROP already says);
* **every other sample** (decisions, statuses, events) takes a slot of its *lane*; when all
  of a lane's slots are taken the *arriving* sample is dropped (tail drop) and counted in
  ``dropped``, so what already waits keeps its order. Lanes keep traffic apart that must not
  compete: the sim takes robot commands in a lane of their own (``Service.on(lane=...)``), so
  a flood of statuses that anyone can provoke (2,000 forged Actions, each answered by a
  refusal) can fill its own lane but never push a command out. One queue keeps the order of
  arrival across lanes;
* work the service schedules for itself (``call_soon``, e.g. a reset query answered on the
  service thread) is never dropped: its callers are bounded already (one Zenoh thread waits
  per query).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Hashable
from typing import Any

Work = tuple[Callable[[Any], None], Any]

#: Slots for samples that are never coalesced; a service at full speed drains it in ~1 s.
DEFAULT_CAPACITY = 1024
#: The lane of every sample whose subscription names none.
DEFAULT_LANE = "default"


class Inbox:
    """A FIFO of ``(handler, argument)`` pairs, bounded as the module docstring says."""

    def __init__(self, capacity: int = DEFAULT_CAPACITY) -> None:
        if capacity < 1:
            raise ValueError(f"capacity: must be >= 1, got {capacity}")
        #: Slots of each lane (every lane has as many).
        self.capacity = capacity
        self.dropped = 0
        #: Samples dropped by lane.
        self.dropped_by_lane: dict[str, int] = {}
        self.coalesced = 0
        self._queue: deque[object] = deque()
        self._latest: dict[Hashable, Work] = {}
        self._bounded: dict[str, int] = {}  # entries of _queue that count against a lane
        self._ready = threading.Condition(threading.Lock())

    def put(self, handler: Callable[[Any], None], argument: Any, lane: str = DEFAULT_LANE) -> bool:
        """Queue one sample in ``lane``; False if that lane was full and it was dropped."""
        with self._ready:
            taken = self._bounded.get(lane, 0)
            if taken >= self.capacity:
                self.dropped += 1
                self.dropped_by_lane[lane] = self.dropped_by_lane.get(lane, 0) + 1
                return False
            self._queue.append(_Bounded(lane, (handler, argument)))
            self._bounded[lane] = taken + 1
            self._ready.notify()
            return True

    def put_latest(self, slot: Hashable, handler: Callable[[Any], None], argument: Any) -> None:
        """Queue ``argument`` for ``slot``, replacing one of the same slot still waiting."""
        with self._ready:
            if slot in self._latest:
                self.coalesced += 1
            else:
                self._queue.append(_Slot(slot))
            self._latest[slot] = (handler, argument)
            self._ready.notify()

    def put_unbounded(self, handler: Callable[[Any], None], argument: Any) -> None:
        """Queue the service's own work: never dropped."""
        with self._ready:
            self._queue.append(_Own((handler, argument)))
            self._ready.notify()

    def get(self, timeout: float) -> Work | None:
        """The oldest waiting work, or None after ``timeout`` seconds."""
        return self.pop() if self.wait(timeout) else None

    def wait(self, timeout: float) -> bool:
        """Whether work waits, after at most ``timeout`` seconds; takes nothing."""
        deadline = time.monotonic() + timeout
        with self._ready:
            while not self._queue:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                self._ready.wait(remaining)
            return True

    def pop(self) -> Work | None:
        """The oldest waiting work, or None at once if none waits."""
        with self._ready:
            if not self._queue:
                return None
            entry = self._queue.popleft()
            if isinstance(entry, _Slot):
                return self._latest.pop(entry.slot)
            if isinstance(entry, _Own):
                return entry.work
            assert isinstance(entry, _Bounded)
            self._bounded[entry.lane] -= 1
            return entry.work

    def __len__(self) -> int:
        with self._ready:
            return len(self._queue)


class _Slot:
    __slots__ = ("slot",)

    def __init__(self, slot: Hashable) -> None:
        self.slot = slot


class _Own:
    __slots__ = ("work",)

    def __init__(self, work: Work) -> None:
        self.work = work


class _Bounded:
    __slots__ = ("lane", "work")

    def __init__(self, lane: str, work: Work) -> None:
        self.lane = lane
        self.work = work
