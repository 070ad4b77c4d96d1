"""What an episode is made of: its objects (ids, categories, sizes) and its goals.

The sim publishes the layout of every episode it lays out. A Scene source that cannot see
goals (perception: goals are places, not things with markers) takes them from here, and the
object list tells it which objects to look for. A real lab describes the same in a layout
file (``manigraph perception --layout FILE``).
"""

from __future__ import annotations

from typing import Annotated, ClassVar

import msgspec
from msgspec import Meta

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp, Struct, Vector3
from manigraph_shared.messages.scene import (
    MAX_ENTITIES,
    Accepts,
    Attributes,
    GoalAttributes,
    GoalCategory,
    ObjectCategory,
)


class LayoutObject(Struct, frozen=True, kw_only=True):
    """A movable object the episode starts with."""

    id: Identifier
    category: ObjectCategory
    size: Annotated[Vector3, Meta(description="full extents along the object's axes, metres")]
    position: Annotated[
        Vector3, Meta(description="where it starts (centre, metres, robot base frame)")
    ]
    attributes: Attributes = msgspec.field(default_factory=dict)


class LayoutGoal(Struct, frozen=True, kw_only=True):
    """A place an object of ``category`` should end up."""

    id: Identifier
    category: GoalCategory
    position: Annotated[Vector3, Meta(description="where the object's centre should be, metres")]
    optional: Annotated[bool, Meta(description="may stay empty at the end (cover storage)")] = False
    accepts: Accepts = msgspec.field(default_factory=dict)
    attributes: GoalAttributes = msgspec.field(default_factory=dict)


class LayoutContainer(Struct, frozen=True, kw_only=True):
    """A static open-top box standing on the table (z = 0)."""

    id: Identifier
    centre: Annotated[Vector3, Meta(description="centre of its floor, metres")]
    inner: Annotated[Vector3, Meta(description="inner width, depth and wall height, metres")]


class TaskLayout(Message, frozen=True, kw_only=True):
    """The objects, goals and boxes of the running episode."""

    key: ClassVar[str] = "manigraph/world/layout"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim (or perception from a layout file)"

    episode_id: Identifier
    stamp: Stamp
    objects: Annotated[list[LayoutObject], Meta(max_length=MAX_ENTITIES)]
    goals: Annotated[list[LayoutGoal], Meta(min_length=1, max_length=MAX_ENTITIES)]
    containers: Annotated[list[LayoutContainer], Meta(max_length=16)] = msgspec.field(
        default_factory=list
    )
    partially_observable: Annotated[bool, Meta(description="closed boxes hide what they hold")] = (
        False
    )

    def _check(self) -> None:
        names = [o.id for o in self.objects] + [g.id for g in self.goals]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"id: used twice: {', '.join(twice)}")
