"""A typed layer over one Zenoh session: publish, subscribe, query and liveliness by message type.

Every ``Message`` subclass already says which key it uses and how it is delivered, so callers
publish and subscribe with types, never with raw keys or bytes. Decoding failures are handed to
an error callback with the offending field named; they never reach the message callback and
never kill the subscriber.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import re
import socket
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import zenoh

from manigraph_shared.bus_config import BusConfig
from manigraph_shared.cells import cell_key
from manigraph_shared.errors import (
    RUNTIME_EXIT_CODE,
    BusError,
    ManigraphError,
    MessageError,
    RequestFailed,
    RequestRefused,
)
from manigraph_shared.messages import Delivery, Message

log = logging.getLogger(__name__)

M = TypeVar("M", bound=Message)
R = TypeVar("R", bound=Message)

ALIVE_PREFIX = "manigraph/alive"
#: Zenoh's own default query timeout; queries here use less so an answer is never late.
DEFAULT_QUERY_TIMEOUT = 5.0
_ATTEMPT_MS = 2000
_RETRY_MS = 100


class NoStackError(BusError):
    """Nobody listens at any endpoint a client was given: there is no stack to reach."""


def open_session(config: BusConfig, overrides: Mapping[str, object] | None = None) -> zenoh.Session:
    """Open a session; a client retries until its router answers or ``wait_seconds`` pass.

    A client with ``no_stack_after`` first checks that something listens at one of its
    endpoints, and raises :class:`NoStackError` naming them if nothing does for that long.
    ``overrides`` are further Zenoh configuration keys (the router's access control).
    """
    if config.mode == "client" and config.no_stack_after is not None:
        _wait_for_a_listener(config.connect, config.no_stack_after)
    deadline = None if config.wait_seconds is None else time.monotonic() + config.wait_seconds
    attempt = 0
    while True:
        attempt += 1
        zconfig = zenoh.Config.from_file(str(config.config_file)) if config.config_file else None
        zconfig = zconfig or zenoh.Config()
        for key, value in {**config.zenoh_json(), **(overrides or {})}.items():
            zconfig.insert_json5(key, _json(value))
        if config.mode != "router":
            zconfig.insert_json5("connect/timeout_ms", str(_ATTEMPT_MS))
            zconfig.insert_json5("connect/exit_on_failure", "true")
            # Retry a refused connection soon (Zenoh waits 1 s by default): services started
            # beside their router then connect within ~0.1 s of it listening.
            zconfig.insert_json5("connect/retry", _json({"period_init_ms": _RETRY_MS}))
        try:
            return zenoh.open(zconfig)
        except zenoh.ZError as exc:
            why = zenoh_reason(exc)
            if config.mode == "router" or (deadline is not None and time.monotonic() > deadline):
                raise BusError(f"cannot open a {config.describe()} session: {why}") from None
            if attempt == 1 or attempt % 5 == 0:
                log.info("waiting for the zenoh router at %s (%s)", ",".join(config.connect), why)
            time.sleep(0.2)


#: Where in its own Rust sources Zenoh raised an error: `` at /root/.cargo/.../x.rs:388.``
_RUST_PLACE = re.compile(r"\s*\bat \S+\.rs:\d+\.?")


def zenoh_reason(exc: BaseException) -> str:
    """A Zenoh error's text without the Rust source place no user can act on."""
    return _RUST_PLACE.sub("", str(exc)).strip() or type(exc).__name__


def _socket_address(endpoint: str) -> tuple[str, int] | None:
    """``(host, port)`` of a TCP or TLS endpoint (``tcp/127.0.0.1:7447``, ``tls/[::1]:7447``,
    metadata after ``?`` or ``#`` ignored); None for any other kind of link."""
    protocol, _, address = endpoint.partition("/")
    if protocol not in ("tcp", "tls"):
        return None
    host, _, port = re.split(r"[?#]", address, maxsplit=1)[0].rpartition(":")
    if not host or not port.isdigit():
        return None
    return host.strip("[]"), int(port)


def _wait_for_a_listener(endpoints: tuple[str, ...], seconds: float) -> None:
    """Return once a TCP connection to one of ``endpoints`` is accepted (a router's kernel
    accepts it even while the router is busy); raise :class:`NoStackError` if none is for
    ``seconds``. Endpoints of other kinds are left to Zenoh."""
    addresses = [_socket_address(endpoint) for endpoint in endpoints]
    if not addresses or any(address is None for address in addresses):
        return
    deadline = time.monotonic() + seconds
    while True:
        for address in addresses:
            assert address is not None
            left = max(0.05, deadline - time.monotonic())
            try:
                with socket.create_connection(address, timeout=min(left, 0.5)):
                    return
            except OSError:
                pass
        if time.monotonic() >= deadline:
            raise NoStackError(f"no stack at {', '.join(endpoints)}{_hint(endpoints)}")
        time.sleep(0.1)


def _hint(endpoints: tuple[str, ...]) -> str:
    """What to start: ``manigraph up`` where the one endpoint is on this machine."""
    address = _socket_address(endpoints[0]) if len(endpoints) == 1 else None
    if address is None or address[0] not in ("127.0.0.1", "localhost", "::1"):
        return " (is its router running, and reachable from here?)"
    secure = " --secure" if endpoints[0].startswith("tls/") else ""
    return f" (is `manigraph up{secure} --port {address[1]}` running?)"


def _json(value: object) -> str:
    import json

    return json.dumps(value)


class Bus:
    """One process's connection to the manigraph bus."""

    def __init__(
        self, session: zenoh.Session, cell: str | None = None, owns_session: bool = True
    ) -> None:
        self.session = session
        #: The robot cell every key of this bus is in (:mod:`manigraph_shared.cells`);
        #: ``None``: the default cell, today's keys.
        self.cell = cell
        #: Whether :meth:`close` closes the session too (not for a view from :meth:`in_cell`).
        self.owns_session = owns_session
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._lock = threading.Lock()
        self._declared: list[Any] = []

    @classmethod
    def open(cls, config: BusConfig, overrides: Mapping[str, object] | None = None) -> Bus:
        return cls(open_session(config, overrides), config.cell)

    def in_cell(self, cell: str | None) -> Bus:
        """A view of this bus's session in ``cell``: its own declarations, which its
        :meth:`close` undeclares, leaving the session (and the other views) open. One process
        serves several cells this way on one session."""
        return Bus(self.session, cell, owns_session=False)

    def scoped(self, key: str) -> str:
        """``key``, declared for the default cell, in this bus's cell."""
        return cell_key(key, self.cell)

    # --- pub/sub ----------------------------------------------------------------------------
    def publish(self, message: Message) -> None:
        key = self.scoped(message.key_for())
        with self._lock:
            publisher = self._publishers.get(key)
            if publisher is None:
                publisher = self.session.declare_publisher(
                    key, reliability=zenoh.Reliability.RELIABLE, **_qos_for(message.delivery)
                )
                self._publishers[key] = publisher
        publisher.put(message.encode(), encoding=_encoding(type(message)))

    def subscribe(
        self,
        message_type: type[M],
        on_message: Callable[[M], None],
        on_error: Callable[[ManigraphError], None] | None = None,
        key: str | None = None,
    ) -> None:
        """Call ``on_message`` (on a Zenoh thread) for each valid sample of ``message_type``."""
        key = self.scoped(key or message_type.key_pattern())

        def deliver(sample: zenoh.Sample) -> None:
            sample_key = str(sample.key_expr)
            try:
                message = message_type.decode(sample.payload.to_bytes(), sample_key)
            except MessageError as exc:
                _report(on_error, exc)
                return
            try:
                on_message(message)
            except Exception as exc:  # a callback bug must not silence the subscriber
                log.exception("handler for %s failed", message_type.type_name())
                _report(on_error, ManigraphError(f"handler for {sample_key} failed: {exc!r}"))

        self._declared.append(self.session.declare_subscriber(key, deliver))

    def subscribe_raw(self, key: str, on_sample: Callable[[zenoh.Sample], None]) -> None:
        """Every sample under ``key`` undecoded (the recorder's view)."""
        self._declared.append(self.session.declare_subscriber(self.scoped(key), on_sample))

    def put_raw(self, key: str, payload: bytes, delivery: Delivery = Delivery.RELIABLE) -> None:
        """Publish bytes as recorded (replay): the receiver validates them as usual."""
        self.session.put(self.scoped(key), payload, **_qos_for(delivery))

    # --- request / reply --------------------------------------------------------------------
    def serve(
        self,
        request_type: type[M],
        handler: Callable[[M], Message],
        key: str | None = None,
    ) -> None:
        """Answer queries on ``request_type.key``; errors become error replies, never silence."""
        key = self.scoped(key or request_type.key)

        def answer(query: zenoh.Query) -> None:
            try:
                if query.payload is None:
                    raise MessageError(request_type.type_name(), key, [("<payload>", "missing")])
                request = request_type.decode(query.payload.to_bytes(), key)
                reply = handler(request)
                query.reply(key, reply.encode(), encoding=_encoding(type(reply)))
            except ManigraphError as exc:
                query.reply_err(str(exc), encoding=_error_encoding(exc.exit_code))
            except Exception as exc:
                log.exception("queryable %s failed", key)
                query.reply_err(
                    f"internal error: {exc!r}", encoding=_error_encoding(RUNTIME_EXIT_CODE)
                )

        self._declared.append(self.session.declare_queryable(key, answer))

    def request(
        self,
        request: Message,
        reply_type: type[R],
        timeout: float = DEFAULT_QUERY_TIMEOUT,
        key: str | None = None,
    ) -> R:
        """Send ``request`` to its queryable and decode the one reply, or raise ``BusError``:
        ``RequestRefused`` for an error reply (``RequestFailed`` where the queryable said it
        could not do it now, the runtime kind of error)."""
        key = self.scoped(key or request.key_for())
        replies = self.session.get(key, payload=request.encode(), timeout=timeout)
        for reply in replies:
            if reply.ok is not None:
                return reply_type.decode(reply.ok.payload.to_bytes(), key)
            error = reply.err.payload.to_string() if reply.err is not None else "error reply"
            runtime = reply.err is not None and reply.err.encoding == _RUNTIME_ERROR
            raise (RequestFailed if runtime else RequestRefused)(f"{key}: {error}")
        raise BusError(f"{key}: no answer within {timeout:.1f} s (is the service running?)")

    # --- liveliness -------------------------------------------------------------------------
    def declare_alive(self, service: str) -> None:
        token = self.session.liveliness().declare_token(f"{self._alive_prefix}/{service}")
        self._declared.append(token)

    @property
    def _alive_prefix(self) -> str:
        return self.scoped(ALIVE_PREFIX)

    def alive_services(self, timeout: float = 2.0) -> set[str]:
        names = set()
        prefix = self._alive_prefix
        for reply in self.session.liveliness().get(f"{prefix}/**", timeout=timeout):
            if reply.ok is not None:
                names.add(str(reply.ok.key_expr).removeprefix(f"{prefix}/"))
        return names

    def watch_alive(self, on_change: Callable[[str, bool], None]) -> None:
        """Call ``on_change(service, alive)`` (on a Zenoh thread) for every service alive now
        and whenever a service's liveliness token appears or disappears; a killed process's
        token goes within milliseconds."""

        prefix = self._alive_prefix

        def changed(sample: zenoh.Sample) -> None:
            name = str(sample.key_expr).removeprefix(f"{prefix}/")
            try:
                on_change(name, sample.kind == zenoh.SampleKind.PUT)
            except Exception:  # a callback bug must not silence the watcher
                log.exception("liveliness callback failed")

        self._declared.append(
            self.session.liveliness().declare_subscriber(f"{prefix}/**", changed, history=True)
        )

    def close(self) -> None:
        for entity in reversed(self._declared):
            with contextlib.suppress(zenoh.ZError):
                entity.undeclare()
        self._declared.clear()
        if not self.owns_session:  # the session stays: its publishers go with the view
            with self._lock:
                publishers, self._publishers = list(self._publishers.values()), {}
            for publisher in publishers:
                with contextlib.suppress(zenoh.ZError):
                    publisher.undeclare()
        elif not self.session.is_closed():
            self.session.close()

    def __enter__(self) -> Bus:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()


def _report(on_error: Callable[[ManigraphError], None] | None, exc: ManigraphError) -> None:
    if on_error is None:
        log.warning("%s", exc)
    else:
        on_error(exc)


def _qos_for(delivery: Delivery) -> dict[str, Any]:
    if delivery is Delivery.LATEST:
        return {
            "congestion_control": zenoh.CongestionControl.DROP,
            "priority": zenoh.Priority.DATA,
            "express": True,
        }
    return {
        "congestion_control": zenoh.CongestionControl.BLOCK,
        "priority": zenoh.Priority.DATA,
        "express": True,
    }


@functools.cache
def _error_encoding(exit_code: int) -> zenoh.Encoding:
    """The encoding of an error reply: its text, and its kind by the exit status it means, so
    the querier raises the same kind (``text/plain;manigraph-exit-1``: :class:`RequestFailed`;
    any other, or none from an older service: :class:`RequestRefused`)."""
    return zenoh.Encoding.TEXT_PLAIN.with_schema(f"manigraph-exit-{exit_code}")


_RUNTIME_ERROR = _error_encoding(RUNTIME_EXIT_CODE)


def _encoding(message_type: type[Message]) -> zenoh.Encoding:
    """The Zenoh encoding of a type's samples, built once per type (a publish is hot)."""
    return zenoh.Encoding.APPLICATION_JSON.with_schema(message_type.type_name())
