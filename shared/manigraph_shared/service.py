"""What every manigraph service process shares: a bus, one inbox, health, clean shutdown.

Service logic lives in plain classes that take and return messages; a :class:`Service` only
wires them to the bus. The handlers of one service run one at a time, in arrival order, so the
logic needs no locks: on the service thread, or (``inline``, see :meth:`Service.on`) on the
Zenoh thread a sample arrived on when the service was idle. A payload that fails validation
is logged, counted and reported as an error ``ServiceStatus`` (so it also lands in the MCAP
log) and the service keeps running.

What a flood can cost is bounded: the inbox holds at most ``INBOX_CAPACITY`` samples and one
waiting sample per state stream (:mod:`manigraph_shared.inbox` states the overflow policy);
rejected payloads are reported individually up to ``REJECTION_REPORTS_PER_SECOND`` (the rest
are counted and the count goes with the next report); after a burst the service hands freed
heap back to the OS (``malloc_trim``), so its RSS returns to where it was.

Every heartbeat also says what the service is (:mod:`manigraph_shared.service_facts`): its
version, when it started, the emergency stop as it last heard of it, and for the planner the
policy and its checkpoint. The same status answers a query on the heartbeat's own key at once,
so ``manigraph status`` need not wait for the next beat.

The service thread publishes a ``ServiceStatus`` heartbeat every ``HEARTBEAT_SECONDS``: a
service whose liveliness token is there but whose heartbeats stop is *stalled* (a handler that
never returns), and ``manigraph doctor`` reports it so. With ``MANIGRAPH_HEALTH_FILE`` set
(the images set it) the same beat also touches that file while the session reaches a router,
so a container's health check is one ``find`` of a fresh file (:mod:`manigraph_shared.health`)
instead of a Python process and a Zenoh session, which on a loaded machine outlasted Docker's
check timeout.

A valid message a service will not act on (a scene of another episode, an action while
stopped) is refused with :meth:`Service.reject`. Every refusal, malformed or not, is counted
by ``<Type>:<reason>`` and published with every heartbeat (``ServiceStatus.rejections``)."""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import logging
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, ClassVar, TypeVar

import zenoh

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.errors import ManigraphError, MessageError
from manigraph_shared.estop_latch import FIRST_ANSWER_SECONDS, NEVER_ENGAGED, EstopLatch
from manigraph_shared.health import HealthFile
from manigraph_shared.inbox import DEFAULT_CAPACITY, DEFAULT_LANE, Inbox
from manigraph_shared.messages import (
    Checkpoint,
    Delivery,
    EmergencyStop,
    EstopState,
    Message,
    Scene,
    ServiceState,
    ServiceStatus,
)
from manigraph_shared.messages.status import MAX_REJECTION_KINDS
from manigraph_shared.scene_gate import SceneGate
from manigraph_shared.service_facts import package_version

M = TypeVar("M", bound=Message)
HEARTBEAT_SECONDS = 1.0
INBOX_CAPACITY = DEFAULT_CAPACITY
#: Rejected payloads reported one by one (log line + error status) per second, at most; a
#: burst of up to ``REJECTION_BURST`` is reported in full.
REJECTION_REPORTS_PER_SECOND = 10.0
REJECTION_BURST = 20
#: Messages handled or rejected since the last trim that make a heap trim worthwhile.
TRIM_AFTER_MESSAGES = 1000

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
    tick_period: float | None = None
    #: The last error reported (its status's ``detail`` until cleared).
    last_error: str

    def __init__(self, bus: Bus) -> None:
        self.bus = bus
        self.log = logging.getLogger(f"manigraph.{self.name}")
        self._inbox = Inbox(INBOX_CAPACITY)
        #: Held while a handler runs, on the service thread or inline on a Zenoh thread:
        #: handlers never overlap, so the service's logic still needs no locks.
        self._turn = threading.Lock()
        self.messages_in = 0
        self.rejections = Rejections()
        self.last_error: str = ""
        self.stop_event = threading.Event()
        self._errors_to_report: deque[ManigraphError] = deque()
        self._rejections_unreported = 0
        self._rejection_lock = threading.Lock()
        self._report_tokens = float(REJECTION_BURST)
        self._tokens_at = time.monotonic()
        self._dropped_reported = 0
        self._activity_at_trim = 0
        self.version = package_version(type(self).__module__)
        self.started_at = time.time()
        #: The emergency stop as this service knows it: unknown (acting as stopped) until the
        #: stack's latch answers; every stop heard since (:mod:`manigraph_shared.estop_latch`).
        self.estop = EstopLatch(on_change=self._estop_changed)
        self._latch_thread: threading.Thread | None = None
        #: What the service serves, for its status (the planner sets them).
        self.policy: str | None = None
        self.checkpoint: Checkpoint | None = None
        self._status_queryable: zenoh.Queryable[Any] | None = None

    @property
    def messages_rejected(self) -> int:
        return self.rejections.total

    # --- wiring -----------------------------------------------------------------------------
    def on(
        self,
        message_type: type[M],
        handler: Callable[[M], None],
        key: str | None = None,
        inline: bool = False,
        lane: str = DEFAULT_LANE,
    ) -> None:
        """Run ``handler`` on the service thread for every valid ``message_type`` sample
        (state streams coalesced to the newest waiting sample, the rest bounded per ``lane``:
        what must never be pushed out by other traffic gets a lane of its own).

        ``inline``: when no handler is running and nothing waits, run it at once on the Zenoh
        thread that decoded the sample, not after a hand-over to the service thread (which
        costs a thread wake-up both ways, ~0.1-0.2 ms on two cores). Order and exclusion are
        kept: a sample that finds a handler running, or work waiting, queues as usual. Only
        for short handlers: the Zenoh thread receives nothing else meanwhile."""
        if message_type.delivery is Delivery.LATEST:
            slot = (message_type.type_name(), key, id(handler))

            def enqueue(message: M) -> None:
                self._inbox.put_latest(slot, handler, message)

        else:

            def enqueue(message: M) -> None:
                self._inbox.put(handler, message, lane)

        def deliver(message: M) -> None:
            if not (inline and self._run_inline(handler, message)):
                enqueue(message)

        self.bus.subscribe(message_type, deliver, on_error=self._rejected, key=key)

    def _run_inline(self, handler: Callable[[Any], None], message: Any) -> bool:
        """Run ``handler`` now if it is the service's turn to be idle; False if it must queue."""
        if not self._turn.acquire(blocking=False):
            return False
        try:
            if len(self._inbox):  # older work first
                return False
            self.messages_in += 1
            self._dispatch(handler, message)
            return True
        finally:
            self._turn.release()

    def call_soon(self, handler: Callable[[Any], None], argument: Any = None) -> bool:
        """Run ``handler(argument)`` on the service thread: the service's own work, never
        dropped (so always True)."""
        self._inbox.put_unbounded(handler, argument)
        return True

    def admit(self, gate: SceneGate, scene: Scene) -> bool:
        """Whether ``scene`` passes ``gate`` (:mod:`manigraph_shared.scene_gate`); one it
        refuses is counted and logged like any rejection. Every service that takes scenes
        hands them over this way."""
        reason = gate.check(scene)
        if reason is not None:
            # The next episode's first scene overtaking its start event happens at every
            # episode boundary: counted (status, doctor) but not a warning nobody can act on.
            quiet = reason == "not_running_episode"
            self.reject(scene, reason, f"{scene.episode_id} #{scene.sequence}", quiet=quiet)
            return False
        return True

    def reject(
        self, message: Message | str, reason: str, detail: str = "", quiet: bool = False
    ) -> None:
        """Refuse a valid ``message`` (or a message type's name): count it by type and
        ``reason``, log it now and then (``quiet``: at debug level only). Safe from any
        thread; never blocks."""
        name = message if isinstance(message, str) else type(message).type_name()
        kind = f"{type_label(name)}:{reason}"
        if self.rejections.add(kind):
            level = logging.DEBUG if quiet else logging.WARNING
            self.log.log(level, "refused %s%s", kind, f" ({detail})" if detail else "")

    def setup(self) -> None:
        """Declare subscriptions, queryables and publishers."""

    def on_estop(self, state: EstopState) -> None:
        """The emergency stop changed (engaged, released, or learned): act on it at once, on
        the thread that learned it. Runs once before :meth:`setup` with the unknown state,
        which is engaged: a service that can move the robot halts it there."""

    def _estop_changed(self, state: EstopState) -> None:
        self.on_estop(state)
        if not state.engaged and state.reason == NEVER_ENGAGED:  # the usual start: no news
            self.log.info("emergency stop: released (never engaged on this stack)")
        elif state.engaged:
            self.log.warning(
                "EMERGENCY STOP %s: %s%s",
                "engaged" if state.known else "state unknown, acting as engaged",
                state.reason or "(no reason)",
                f" (by {state.by})" if state.by else "",
            )
        else:
            self.log.warning("emergency stop released: %s", state.reason or "(no reason)")
        self.call_soon(lambda _: self.publish_status(ServiceState.OK, self.last_error))

    def _follow_latch(self) -> None:
        """Ask the stack's latch again now and then (a thread of its own: never the service
        thread's time)."""
        while not self.stop_event.wait(0.1):
            if self.estop.due(time.monotonic()):
                self.estop.ask(self.bus)

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
        self.bus.publish(self.status(state, detail))

    def status(self, state: ServiceState, detail: str = "") -> ServiceStatus:
        """The service's status now: its health and what it is (version, uptime, stop)."""
        return ServiceStatus(
            service=self.name,
            state=state,
            detail=detail[:2048],
            messages_in=self.messages_in,
            messages_rejected=self.messages_rejected,
            rejections=self.rejections.snapshot(),
            version=self.version,
            started_at=self.started_at,
            policy=self.policy,
            checkpoint=self.checkpoint,
            estop=self.estop.state,
            stamp=time.time(),
        )

    def _serve_status(self) -> None:
        """Answer a query on the heartbeat's key with the status now (from the Zenoh thread,
        so even a busy service answers at once; a stalled one shows in its heartbeats)."""
        key = self.bus.scoped(ServiceStatus.key.format(service=self.name))
        encoding = zenoh.Encoding.APPLICATION_JSON.with_schema(ServiceStatus.type_name())

        def answer(query: zenoh.Query) -> None:
            status = self.status(ServiceState.OK, self.last_error)
            try:
                query.reply(key, status.encode(), encoding=encoding)
            except zenoh.ZError as exc:  # the querier went away meanwhile
                self.log.debug("status query not answered: %s", exc)

        self._status_queryable = self.bus.session.declare_queryable(key, answer)

    def _rejected(self, error: ManigraphError) -> None:
        # Zenoh thread: count here, report on the service thread (bounded, see run).
        name = error.message_type if isinstance(error, MessageError) else "handler"
        self.rejections.add(f"{type_label(name)}:invalid")
        with self._rejection_lock:
            if len(self._errors_to_report) < REJECTION_BURST:
                self._errors_to_report.append(error)
            else:
                self._rejections_unreported += 1

    def _report_rejections(self, now: float) -> None:
        """Report waiting rejections within the rate budget (a token bucket)."""
        self._report_tokens = min(
            float(REJECTION_BURST),
            self._report_tokens + (now - self._tokens_at) * REJECTION_REPORTS_PER_SECOND,
        )
        self._tokens_at = now
        while self._report_tokens >= 1.0:
            with self._rejection_lock:
                if not self._errors_to_report:
                    break
                error = self._errors_to_report.popleft()
                unreported, self._rejections_unreported = self._rejections_unreported, 0
            self._report_tokens -= 1.0
            suffix = f" (and {unreported} more rejected, not reported one by one)"
            self.report_error(ManigraphError(f"{error}{suffix if unreported else ''}"))
        dropped = self._inbox.dropped
        if dropped > self._dropped_reported:
            self._dropped_reported = dropped
            lanes = ", ".join(f"{lane} {n}" for lane, n in self._inbox.dropped_by_lane.items())
            self.report_error(
                ManigraphError(
                    f"inbox full ({self._inbox.capacity} a lane): {dropped} samples dropped "
                    f"({lanes})"
                )
            )

    def _trim_heap(self) -> None:
        """After a burst, give freed heap back to the OS (glibc keeps it otherwise)."""
        activity = self.messages_in + self.messages_rejected + self._inbox.coalesced
        if activity - self._activity_at_trim >= TRIM_AFTER_MESSAGES and not len(self._inbox):
            self._activity_at_trim = activity
            malloc_trim()

    # --- life cycle -------------------------------------------------------------------------
    def run(self) -> None:
        health = HealthFile.from_environment(self.bus.session)
        self.started_at = time.time()
        self.publish_status(ServiceState.STARTING)
        # Stopped until the stack's latch says otherwise; then every stop heard, and the
        # latch again now and then, all before a handler can act.
        self.on_estop(self.estop.state)
        self.bus.subscribe(EmergencyStop, self.estop.heard)
        if not self.estop.ask(self.bus, FIRST_ANSWER_SECONDS):
            self.log.warning("no answer from the stack's emergency-stop latch: acting as stopped")
        self._latch_thread = threading.Thread(
            target=self._follow_latch, name="estop-latch", daemon=True
        )
        self._latch_thread.start()
        with self._turn:  # no inline handler before the service is set up
            self.setup()
        self._serve_status()
        self.bus.declare_alive(self.name)
        self.publish_status(ServiceState.OK, "ready")
        self.log.info("ready")
        health.beat()
        next_beat = time.monotonic() + HEARTBEAT_SECONDS
        next_tick = time.monotonic()
        try:
            while not self.stop_event.is_set():
                now = time.monotonic()
                wake = min(next_beat, next_tick if self.tick_period else next_beat)
                if self._inbox.wait(timeout=max(0.0, min(wake - now, 0.1))):
                    with self._turn:  # popped under the turn: inline work cannot overtake
                        work = self._inbox.pop()
                        if work is not None:
                            self.messages_in += 1
                            self._dispatch(*work)
                now = time.monotonic()
                self._report_rejections(now)
                if self.tick_period and now >= next_tick:
                    next_tick = now + self.tick_period
                    with self._turn:
                        self._dispatch(lambda _: self.tick(), None)
                if now >= next_beat:
                    next_beat = now + HEARTBEAT_SECONDS
                    self.publish_status(ServiceState.OK, self.last_error)
                    health.beat()
                    self._trim_heap()
        finally:
            self._turn.acquire()  # for good: no inline handler beside or after the teardown
            health.clear()
            if self._status_queryable is not None:
                with contextlib.suppress(zenoh.ZError):
                    self._status_queryable.undeclare()
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


#: glibc's ``M_ARENA_MAX`` (mallopt): at most this many malloc arenas per process. glibc
#: otherwise gives each of Zenoh's many threads its own arena (up to 8 per core), and memory
#: freed after a flood stays stranded in them.
MALLOC_ARENAS = 2
_M_ARENA_MAX = -8


def limit_malloc_arenas(arenas: int = MALLOC_ARENAS) -> None:
    """Cap glibc's malloc arenas (before the bus starts its threads); no-op elsewhere."""
    if _LIBC is not None and hasattr(_LIBC, "mallopt"):
        _LIBC.mallopt(_M_ARENA_MAX, arenas)


def malloc_trim() -> None:
    """Hand the heap's free memory back to the OS (glibc only; elsewhere nothing)."""
    if _LIBC is not None:
        _LIBC.malloc_trim(0)


def _load_libc() -> ctypes.CDLL | None:
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
    except OSError:
        return None
    return libc if libc is not None and hasattr(libc, "malloc_trim") else None  # not musl


_LIBC = _load_libc()


#: Seconds from a service's stop request to the kernel ending it (SIGALRM's default action),
#: whatever the interpreter is doing then. A stop normally takes well under a second; this
#: bounds one stuck where no Python thread can run (a close blocked in native code holding the
#: GIL, say, when the router went down with ``up``), so that no service outlives its stack.
HARD_STOP_S = 30


def request_stop(stop: threading.Event, within_s: int) -> None:
    """Set ``stop``; the first request also arms SIGALRM ``within_s`` seconds out, whose
    default action (set it so) ends a stop that hangs whatever the interpreter is doing. Any
    thread may call it: a signal handler, a watcher."""
    if not stop.is_set():
        signal.alarm(within_s)
    stop.set()


def run_service(factory: Callable[[Bus], Service], bus_config: BusConfig) -> int:
    """Open the bus, run the service until SIGINT/SIGTERM, then close everything; a stop
    that is not done :data:`HARD_STOP_S` seconds after it was asked for ends the process."""
    limit_malloc_arenas()
    # A file left by a killed predecessor (a container's /tmp survives its restart) must not
    # report this process healthy while it is still looking for its router.
    HealthFile.from_environment().clear()
    bus = Bus.open(bus_config)
    service = factory(bus)

    def stop(signum: int, _frame: object) -> None:
        request_stop(service.stop_event, HARD_STOP_S)
        service.log.info("received %s, stopping", signal.Signals(signum).name)

    signal.signal(signal.SIGALRM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    try:
        service.run()
    finally:
        bus.close()
    return 0
