"""The emergency stop: any authorised client may engage it; skills and the sim obey at once."""

from __future__ import annotations

from typing import Annotated, ClassVar

from msgspec import Meta

from manigraph_shared.messages.base import Delivery, Message, Stamp


class EmergencyStop(Message, frozen=True, kw_only=True):
    """Engage (halt the robot, refuse new actions) or release the emergency stop."""

    key: ClassVar[str] = "manigraph/robot/estop"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "any authorised client (`manigraph stop` / `resume`)"

    engaged: Annotated[bool, Meta(description="true: stop now and stay stopped; false: resume")]
    reason: Annotated[str, Meta(max_length=256, description="why, for the log")] = ""
    by: Annotated[
        str, Meta(max_length=128, description="who sent it, e.g. `manigraph stop (ana@cell-pc)`")
    ] = ""
    stamp: Stamp
