"""What every manigraph service process shares: a bus, one inbox, health, clean shutdown.

Service logic lives in plain classes that take and return messages; a :class:`Service` only
wires them to the bus. All handlers of one service run on one thread, in arrival order, so the
logic needs no locks. A payload that fails validation is logged, counted and reported as an
error ``ServiceStatus`` (so it also lands in the MCAP log) and the service keeps running.

The bus is a trust boundary, so nothing a sender does can make a service hold unbounded work:
the inbox holds at most ``inbox_capacity`` messages and a message arriving at a full inbox is
dropped (newest dropped, so what is queued keeps its order) and counted as
``<Type>:inbox_full``. A valid message a service will not act on (a scene of another episode, an
action while stopped) is refused with :meth:`Service.reject`. Every refusal, malformed or not,
is counted by ``<Type>:<reason>`` and published with every heartbeat (``ServiceStatus.rejections``).
"""

from __future__ import annotations

import logging
import queue
import signal
import threading
import time
from collections.abc import Callable
from typing import Any, ClassVar, TypeVar

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.errors import ManigraphError, MessageError
from manigraph_shared.messages import Message, ServiceState, ServiceStatus
from manigraph_shared.messages.status import MAX_REJECTION_KINDS

M = TypeVar("M", bound=Message)
HEARTBEAT_SECONDS = 1.0
#: Messages waiting for the service thread; more are dropped and counted.
INBOX_CAPACITY = 1024
#: A refusal is logged at most this often per ``<Type>:<reason>`` (all are counted).
REJECTION_LOG_SECONDS = 1.0


class Rejections:
    """Thread-safe counters of refused messages by ``<Type>:<reason>``."""

    def __init__(self) -> None:
        self._counts: dict[str, int] = {}
        self._logged: dict[str, float] = {}
        self._lock = threading.Lock()

    def add(self, kind: str) -> bool:
        """Count one refusal; True when it is time to log this kind again."""
        now = time.monotonic()
        with self._lock:
            if kind not in self._counts and len(self._counts) >= MAX_REJECTION_KINDS - 1:
                kind = "other"
            self._counts[kind] = self._counts.get(kind, 0) + 1
            if now - self._logged.get(kind, -REJECTION_LOG_SECONDS) >= REJECTION_LOG_SECONDS:
                self._logged[kind] = now
                return True
            return False

    def snapshot(self) -> dict[str, int]:
        with self._lock:
            return dict(self._counts)

    @property
    def total(self) -> int:
        with self._lock:
            return sum(self._counts.values())


def type_label(message_type: str) -> str:
    """``manigraph.Scene`` -> ``Scene``."""
    return message_type.rsplit(".", 1)[-1]


class Service:
    """Base of the sim, planner, skills, perception and recorder processes."""

    name: ClassVar[str]
    #: How often ``tick`` runs; ``None``: never.
    tick_period: ClassVar[float | None] = None

    #: Messages the inbox holds before it drops new ones.
    inbox_capacity: ClassVar[int] = INBOX_CAPACITY

    def __init__(self, bus: Bus) -> None:
        self.bus = bus
        self.log = logging.getLogger(f"manigraph.{self.name}")
        self._inbox: queue.Queue[tuple[Callable[[Any], None], Any]] = queue.Queue(
            self.inbox_capacity
        )
        self.messages_in = 0
        self.rejections = Rejections()
        self.last_error = ""
        self.stop_event = threading.Event()

    @property
    def messages_rejected(self) -> int:
        return self.rejections.total

    # --- wiring -----------------------------------------------------------------------------
    def on(
        self, message_type: type[M], handler: Callable[[M], None], key: str | None = None
    ) -> None:
        """Run ``handler`` on the service thread for every valid ``message_type`` sample."""

        def enqueue(message: M) -> None:
            if not self.call_soon(handler, message):
                self.reject(message, "inbox_full", f"{self.inbox_capacity} messages waiting")

        self.bus.subscribe(message_type, enqueue, on_error=self._rejected, key=key)

    def call_soon(self, handler: Callable[[Any], None], argument: Any = None) -> bool:
        """Run ``handler(argument)`` on the service thread; False if the inbox is full."""
        try:
            self._inbox.put_nowait((handler, argument))
        except queue.Full:
            return False
        return True

    def reject(self, message: Message | str, reason: str, detail: str = "") -> None:
        """Refuse a valid ``message`` (or a message type's name): count it by type and
        ``reason``, log it now and then. Safe from any thread; never blocks."""
        name = message if isinstance(message, str) else type(message).type_name()
        kind = f"{type_label(name)}:{reason}"
        if self.rejections.add(kind):
            self.log.warning("refused %s%s", kind, f" ({detail})" if detail else "")

    def setup(self) -> None:
        """Declare subscriptions, queryables and publishers."""

    def tick(self) -> None:
        """Periodic work (``tick_period``)."""

    def teardown(self) -> None:
        """Release what ``setup`` took."""

    # --- health -----------------------------------------------------------------------------
    def report_error(self, error: BaseException) -> None:
        self.last_error = str(error)
        self.log.error("%s", error)
        self.publish_status(ServiceState.ERROR, self.last_error)

    def publish_status(self, state: ServiceState, detail: str = "") -> None:
        self.bus.publish(
            ServiceStatus(
                service=self.name,
                state=state,
                detail=detail[:2048],
                messages_in=self.messages_in,
                messages_rejected=self.messages_rejected,
                rejections=self.rejections.snapshot(),
                stamp=time.time(),
            )
        )

    def _rejected(self, error: ManigraphError) -> None:
        # Zenoh thread: count here, report on the service thread (if it has room).
        name = error.message_type if isinstance(error, MessageError) else "handler"
        self.rejections.add(f"{type_label(name)}:invalid")
        self.call_soon(self.report_error, error)

    # --- life cycle -------------------------------------------------------------------------
    def run(self) -> None:
        self.publish_status(ServiceState.STARTING)
        self.setup()
        self.bus.declare_alive(self.name)
        self.publish_status(ServiceState.OK, "ready")
        self.log.info("ready")
        next_beat = time.monotonic() + HEARTBEAT_SECONDS
        next_tick = time.monotonic()
        try:
            while not self.stop_event.is_set():
                now = time.monotonic()
                wake = min(next_beat, next_tick if self.tick_period else next_beat)
                try:
                    handler, argument = self._inbox.get(timeout=max(0.0, min(wake - now, 0.1)))
                except queue.Empty:
                    pass
                else:
                    self.messages_in += 1
                    self._dispatch(handler, argument)
                now = time.monotonic()
                if self.tick_period and now >= next_tick:
                    next_tick = now + self.tick_period
                    self._dispatch(lambda _: self.tick(), None)
                if now >= next_beat:
                    next_beat = now + HEARTBEAT_SECONDS
                    self.publish_status(ServiceState.OK, self.last_error)
        finally:
            self.publish_status(ServiceState.STOPPING)
            self.teardown()
            self.log.info("stopped")

    def _dispatch(self, handler: Callable[[Any], None], argument: Any) -> None:
        try:
            handler(argument)
        except ManigraphError as exc:
            self.report_error(exc)
        except Exception as exc:  # a bug in one handler must not take the service down
            self.log.exception("unexpected error")
            self.report_error(exc)


def run_service(factory: Callable[[Bus], Service], bus_config: BusConfig) -> int:
    """Open the bus, run the service until SIGINT/SIGTERM, then close everything."""
    bus = Bus.open(bus_config)
    service = factory(bus)

    def stop(signum: int, _frame: object) -> None:
        service.log.info("received %s, stopping", signal.Signals(signum).name)
        service.stop_event.set()

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    try:
        service.run()
    finally:
        bus.close()
    return 0
