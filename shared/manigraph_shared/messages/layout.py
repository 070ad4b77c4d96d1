"""What an episode is made of: its objects (ids, categories, sizes) and its goals.

The sim publishes the layout of every episode it lays out. A Scene source that cannot see
goals (perception: goals are places, not things with markers) takes them from here, and the
object list tells it which objects to look for. A real lab describes the same in a layout
file (``manigraph perception --layout FILE``).
"""

from __future__ import annotations

from typing import ClassVar, Self

from pydantic import Field, model_validator

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp, Struct, Vector3
from manigraph_shared.messages.scene import MAX_ENTITIES, GoalCategory, ObjectCategory


class LayoutObject(Struct):
    """A movable object the episode starts with."""

    id: Identifier
    category: ObjectCategory
    size: Vector3 = Field(description="full extents along the object's axes, metres")
    position: Vector3 = Field(description="where it starts (centre, metres, robot base frame)")


class LayoutGoal(Struct):
    """A place an object of ``category`` should end up."""

    id: Identifier
    category: GoalCategory
    position: Vector3 = Field(description="where the object's centre should be, metres")
    optional: bool = Field(False, description="may stay empty at the end (cover storage)")


class LayoutContainer(Struct):
    """A static open-top box standing on the table (z = 0)."""

    id: Identifier
    centre: Vector3 = Field(description="centre of its floor, metres")
    inner: Vector3 = Field(description="inner width, depth and wall height, metres")


class TaskLayout(Message):
    """The objects, goals and boxes of the running episode."""

    key: ClassVar[str] = "manigraph/world/layout"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim (or perception from a layout file)"

    episode_id: Identifier
    stamp: Stamp
    objects: list[LayoutObject] = Field(max_length=MAX_ENTITIES)
    goals: list[LayoutGoal] = Field(min_length=1, max_length=MAX_ENTITIES)
    containers: list[LayoutContainer] = Field(default_factory=list, max_length=16)
    partially_observable: bool = Field(False, description="closed boxes hide what they hold")

    @model_validator(mode="after")
    def _unique_ids(self) -> Self:
        names = [o.id for o in self.objects] + [g.id for g in self.goals]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"id: used twice: {', '.join(twice)}")
        return self
