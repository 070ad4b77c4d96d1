"""What the world looks like: objects and goals with poses, published by sim or perception."""

from __future__ import annotations

from enum import StrEnum
from typing import ClassVar, Self

from pydantic import Field, model_validator

from manigraph_shared.messages.base import (
    Delivery,
    Identifier,
    Message,
    Quaternion,
    Stamp,
    Struct,
    Vector3,
)

MAX_ENTITIES = 256


class ObjectCategory(StrEnum):
    """What kind of thing an object is (the paper's node categories 0 and 1)."""

    COVER = "cover"
    BLOCK = "block"
    #: Dishes of the dishwasher task (docs/dishwasher.md).
    PLATE = "plate"
    BOWL = "bowl"


class GoalCategory(StrEnum):
    """Which category of object a goal accepts (the paper's node categories 2 and 3; a
    dishwasher rack's slots take a plate or a bowl)."""

    BLOCK = "block"
    COVER = "cover"
    PLATE = "plate"
    BOWL = "bowl"


class SceneObject(Struct):
    """A movable object."""

    id: Identifier
    category: ObjectCategory
    position: Vector3 = Field(description="centre of the object, metres, in the scene frame")
    orientation: Quaternion = Quaternion()
    size: Vector3 = Field(description="full extents along the object's axes, metres")
    filled: bool = Field(False, description="the object rests in a goal of its category")
    visible: bool = Field(True, description="observed now (false: occluded or inside a box)")

    @model_validator(mode="after")
    def _positive_size(self) -> Self:
        if min(self.size.as_tuple()) <= 0.0 or max(self.size.as_tuple()) > 2.0:
            raise ValueError("size: every extent must be in (0, 2] metres")
        return self


class SceneGoal(Struct):
    """A place an object of ``category`` should end up."""

    id: Identifier
    category: GoalCategory
    position: Vector3 = Field(description="where the object's centre should be, metres")
    orientation: Quaternion = Quaternion()
    filled: bool = Field(False, description="an object of the right category occupies it")
    visible: bool = Field(True, description="observed now (false: inside a closed box)")
    rack: Identifier | None = Field(None, description="the dishwasher rack holding this slot")


class SceneRack(Struct):
    """A dishwasher rack that slides out (open) and in along its rail."""

    id: Identifier
    position: Vector3 = Field(description="centre of the rack's handle, metres")
    open: bool = Field(description="pulled out: it can be loaded")
    travel: float | None = Field(
        None, ge=0.0, le=1.0, description="how far it is out, metres, where measured"
    )
    rail: float | None = Field(
        None,
        gt=0.0,
        le=1.0,
        description="how far it slides out all the way, metres, where the world says so "
        "(None: grasp_points.RACK_TRAVEL)",
    )


class Scene(Message):
    """Poses of every object and goal at one instant."""

    key: ClassVar[str] = "manigraph/world/scene"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim or perception"

    episode_id: Identifier
    frame_id: str = Field("world", max_length=64, description="frame of every position")
    stamp: Stamp
    sequence: int = Field(ge=0, description="increases by one per published scene")
    objects: list[SceneObject] = Field(max_length=MAX_ENTITIES)
    goals: list[SceneGoal] = Field(max_length=MAX_ENTITIES)
    racks: list[SceneRack] = Field(
        default_factory=list, max_length=8, description="dishwasher racks (dishwasher task)"
    )
    episode_ended: bool = Field(
        False, description="the world ended this episode (sim only): planners stop deciding"
    )
    stale: bool = Field(
        False,
        description="perception saw nothing it could use lately: poses are the last known",
    )

    @model_validator(mode="after")
    def _unique_ids(self) -> Self:
        seen: set[str] = set()
        entities: list[SceneObject | SceneGoal | SceneRack] = [
            *self.objects,
            *self.goals,
            *self.racks,
        ]
        for entity in entities:
            if entity.id in seen:
                raise ValueError(f"id: '{entity.id}' is used twice")
            seen.add(entity.id)
        return self

    def object(self, object_id: str) -> SceneObject:
        for item in self.objects:
            if item.id == object_id:
                return item
        raise KeyError(object_id)

    def goal(self, goal_id: str) -> SceneGoal:
        for item in self.goals:
            if item.id == goal_id:
                return item
        raise KeyError(goal_id)

    def rack(self, rack_id: str) -> SceneRack:
        for item in self.racks:
            if item.id == rack_id:
                return item
        raise KeyError(rack_id)
