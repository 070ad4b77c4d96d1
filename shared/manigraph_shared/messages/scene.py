"""What the world looks like: objects and goals with poses, published by sim or perception."""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Any, ClassVar

import msgspec
from msgspec import Meta

from manigraph_shared.messages import legacy
from manigraph_shared.messages.base import (
    MAX_ATTRIBUTES,
    AttributeName,
    Delivery,
    FamilyName,
    FamilyScalar,
    Identifier,
    Message,
    Quaternion,
    Stamp,
    Struct,
    Vector3,
)

MAX_ENTITIES = 256
#: Fixtures one scene may carry.
MAX_FIXTURES = 16
AttributeValue = (
    Annotated[str, Meta(min_length=1, max_length=64)] | Annotated[float, Meta(ge=-1e6, le=1e6)]
)
#: What a goal's ``accepts`` lists under a key: a value an object's attribute must equal, an
#: object id (key ``id``) or full extents (key ``size``, matched within 1 mm).
AcceptValue = (
    AttributeValue
    | Annotated[list[Annotated[float, Meta(gt=0.0, le=2.0)]], Meta(min_length=3, max_length=3)]
)
Attributes = Annotated[
    dict[AttributeName, AttributeValue],
    Meta(
        max_length=MAX_ATTRIBUTES,
        description="what the task tells objects apart by (colour, label, ...): text or number",
    ),
]
GoalAttributes = Annotated[
    dict[AttributeName, AttributeValue],
    Meta(
        max_length=MAX_ATTRIBUTES,
        description="what the task tells goals apart by (a bin's colour, a rack's side): text "
        "or number",
    ),
]
Accepts = Annotated[
    dict[AttributeName, AcceptValue],
    Meta(
        max_length=MAX_ATTRIBUTES,
        description="what an object must carry to fill this goal: every key must match "
        "(an attribute's value, ``id``, or ``size`` within 1 mm); empty: any object of its "
        "category",
    ),
]


FixtureState = Annotated[
    dict[AttributeName, FamilyScalar],
    Meta(
        max_length=MAX_ATTRIBUTES,
        description="the fixture's state as its family reads it (open, travel, ...): flag, "
        "number or text",
    ),
]


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


class SceneObject(Struct, frozen=True, kw_only=True):
    """A movable object."""

    id: Identifier
    category: ObjectCategory
    position: Annotated[
        Vector3, Meta(description="centre of the object, metres, in the scene frame")
    ]
    orientation: Quaternion = Quaternion()
    size: Annotated[Vector3, Meta(description="full extents along the object's axes, metres")]
    filled: Annotated[bool, Meta(description="the object rests in a goal that accepts it")] = False
    visible: Annotated[bool, Meta(description="observed now (false: occluded or inside a box)")] = (
        True
    )
    attributes: Attributes = msgspec.field(default_factory=dict)

    def _check(self) -> None:
        if min(self.size.as_tuple()) <= 0.0 or max(self.size.as_tuple()) > 2.0:
            raise ValueError("size: every extent must be in (0, 2] metres")


class SceneGoal(Struct, frozen=True, kw_only=True):
    """A place an object of ``category`` should end up."""

    id: Identifier
    category: GoalCategory
    position: Annotated[Vector3, Meta(description="where the object's centre should be, metres")]
    orientation: Quaternion = Quaternion()
    filled: Annotated[bool, Meta(description="an object it accepts occupies it")] = False
    visible: Annotated[bool, Meta(description="observed now (false: inside a closed box)")] = True
    fixture: Annotated[
        Identifier | None,
        Meta(description="the fixture holding this goal (``Scene.fixtures``), if any"),
    ] = None
    accepts: Accepts = msgspec.field(default_factory=dict)
    attributes: GoalAttributes = msgspec.field(default_factory=dict)


class SceneFixture(Struct, frozen=True, kw_only=True):
    """A part of the world the robot operates rather than moves (a drawer, a rack on its
    rail): of a ``kind`` the task's family defines, with a ``state`` the family reads."""

    id: Identifier
    kind: Annotated[FamilyName, Meta(description="a kind its family defines (a rack, ...)")]
    position: Annotated[
        Vector3, Meta(description="where the gripper takes the fixture (its handle), metres")
    ]
    orientation: Quaternion = Quaternion()
    size: Annotated[
        Vector3 | None, Meta(description="full extents, metres, where the family says")
    ] = None
    state: FixtureState = msgspec.field(default_factory=dict)


class Scene(Message, frozen=True, kw_only=True):
    """Poses of every object and goal at one instant."""

    key: ClassVar[str] = "manigraph/world/scene"
    delivery: ClassVar[Delivery] = Delivery.LATEST
    publisher: ClassVar[str] = "sim or perception"

    episode_id: Identifier
    frame_id: Annotated[str, Meta(max_length=64, description="frame of every position")] = "world"
    stamp: Stamp
    sequence: Annotated[int, Meta(ge=0, description="increases by one per published scene")]
    objects: Annotated[list[SceneObject], Meta(max_length=MAX_ENTITIES)]
    goals: Annotated[list[SceneGoal], Meta(max_length=MAX_ENTITIES)]
    fixtures: Annotated[
        list[SceneFixture],
        Meta(max_length=MAX_FIXTURES, description="fixtures of the task's family (its racks, ...)"),
    ] = msgspec.field(default_factory=list)
    episode_ended: Annotated[
        bool, Meta(description="the world ended this episode (sim only): planners stop deciding")
    ] = False
    stale: Annotated[
        bool,
        Meta(description="perception saw nothing it could use lately: poses are the last known"),
    ] = False

    def _check(self) -> None:
        seen: set[str] = set()
        entities: list[SceneObject | SceneGoal | SceneFixture] = [
            *self.objects,
            *self.goals,
            *self.fixtures,
        ]
        for entity in entities:
            if entity.id in seen:
                raise ValueError(f"id: '{entity.id}' is used twice")
            seen.add(entity.id)

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

    def fixture(self, fixture_id: str) -> SceneFixture:
        for item in self.fixtures:
            if item.id == fixture_id:
                return item
        raise KeyError(fixture_id)

    @classmethod
    def upgrade(cls, data: dict[str, Any]) -> dict[str, Any]:
        """A scene of contract version 1-3 in this version's fields (:mod:`.legacy`)."""
        return legacy.scene(data)
