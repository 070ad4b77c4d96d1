"""Service health, published periodically and on every error."""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, ClassVar

import msgspec
from msgspec import Meta

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp, Struct

#: Distinct `<Type>:<reason>` counters a status carries (the rest are summed under `other`).
MAX_REJECTION_KINDS = 64


#: A SHA-256 digest in lowercase hex.
Sha256 = Annotated[str, Meta(pattern=r"^[0-9a-f]{64}$", description="SHA-256, lowercase hex")]


class ServiceState(StrEnum):
    STARTING = "starting"
    OK = "ok"
    ERROR = "error"
    STOPPING = "stopping"


class Checkpoint(Struct, frozen=True, kw_only=True):
    """A policy file: where it was loaded from and what it held."""

    path: Annotated[str, Meta(max_length=4096, description="as the service was given it")]
    sha256: Sha256


class EstopState(Struct, frozen=True, kw_only=True):
    """The emergency stop as one service knows it: from the stack's latch (the router keeps
    it across restarts) and every stop heard since. ``known`` came later (default true, so
    older logs decode as they meant)."""

    engaged: bool = False
    known: Annotated[
        bool,
        Meta(
            description="false: the service has not yet learned the stop from the stack's "
            "latch, and acts as stopped (`engaged` is then true)"
        ),
    ] = True
    reason: Annotated[str, Meta(max_length=256, description="the stop's reason")] = ""
    by: Annotated[str, Meta(max_length=128, description="who engaged (or released) it")] = ""
    since: Annotated[
        Annotated[float, Meta(ge=0.0)] | None,
        Meta(description="when the stop was sent (seconds since the Unix epoch)"),
    ] = None


class ServiceStatus(Message, frozen=True, kw_only=True):
    """Heartbeat and error report of one service.

    The fields from ``version`` on came later: each has a default, so older logs still
    decode. The same status answers a query on the service's key (``manigraph status``)."""

    key: ClassVar[str] = "manigraph/status/{service}"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "every service"

    service: Identifier
    state: ServiceState
    detail: Annotated[str, Meta(max_length=2048, description="last error, or what it is doing")] = (
        ""
    )
    messages_in: Annotated[int, Meta(ge=0)] = 0
    messages_rejected: Annotated[
        int, Meta(ge=0, description="every message refused: malformed, or valid but not acceptable")
    ] = 0
    rejections: Annotated[
        dict[str, int],
        Meta(
            max_length=MAX_REJECTION_KINDS,
            description="refusals so far by `<Type>:<reason>`, e.g. `Scene:sequence_jump`",
        ),
    ] = msgspec.field(default_factory=dict)
    version: Annotated[str, Meta(max_length=64, description="the service package's version")] = ""
    started_at: Annotated[
        Annotated[float, Meta(ge=0.0)] | None,
        Meta(description="when the service started (seconds since the Unix epoch)"),
    ] = None
    policy: Annotated[
        Annotated[str, Meta(max_length=128)] | None,
        Meta(description="the policy served (planner)"),
    ] = None
    checkpoint: Annotated[
        Checkpoint | None, Meta(description="the policy's checkpoint file (planner)")
    ] = None
    estop: Annotated[
        EstopState | None, Meta(description="the emergency stop as this service knows it")
    ] = None
    stamp: Stamp
