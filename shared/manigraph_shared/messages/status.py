"""Service health, published periodically and on every error."""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, ClassVar

import msgspec
from msgspec import Meta

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp

#: Distinct `<Type>:<reason>` counters a status carries (the rest are summed under `other`).
MAX_REJECTION_KINDS = 64


class ServiceState(StrEnum):
    STARTING = "starting"
    OK = "ok"
    ERROR = "error"
    STOPPING = "stopping"


class ServiceStatus(Message, frozen=True, kw_only=True):
    """Heartbeat and error report of one service."""

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
    stamp: Stamp
