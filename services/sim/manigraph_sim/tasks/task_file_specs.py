"""The task file's tables as validated records: an object, a goal, a container, and the value
types and robot-reach bounds they are checked against (``manigraph_sim.tasks.task_file`` reads
the file and checks the layout as a whole)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator, model_validator

Coordinate = Annotated[float, Field(ge=-5.0, le=5.0)]
Extent = Annotated[float, Field(gt=0.0, le=2.0)]
Name = Annotated[str, Field(pattern=r"^[A-Za-z0-9_.:\-]{1,64}$")]

#: Where the robot can reach, robot frame, metres: the skills service's default workspace
#: (services never import each other, so the bounds are repeated here). A goal or object
#: outside it, after the layout's random shift, is a layout that cannot happen.
REACH = ((0.1, 0.9), (-0.6, 0.6), (-0.01, 2.0))
#: Bodies may touch (a stack's blocks share a face) but not interpenetrate by more than this.
OVERLAP_TOLERANCE = 1e-3
#: Layout problems named in one error; a file of 256 stacked-up blocks has 32,640 of them.
MAX_PROBLEMS_NAMED = 10
#: A block goal is a place for one block: two closer than this cannot both be filled.
BLOCK_WIDTH = 0.04


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


Position = tuple[Coordinate, Coordinate, Coordinate]


def _no_boolean(value: object) -> object:
    if isinstance(value, bool):
        raise ValueError("true and false are not attribute values: give text or a number")
    return value


#: The contract's attribute names and values (``manigraph_shared.messages.scene``).
AttributeName = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]{0,31}$")]
AttributeValue = Annotated[
    Annotated[str, Field(min_length=1, max_length=64)] | Annotated[float, Field(ge=-1e6, le=1e6)],
    BeforeValidator(_no_boolean),
]
#: Names an object's attributes may not take: a goal's ``accepts`` means the object's own.
RESERVED = ("id", "size")


class ObjectSpec(_Strict):
    id: Name
    category: Literal["block", "cover"]
    position: Position | None = None
    positions: list[Position] | None = Field(None, min_length=1, max_length=64)
    size: tuple[Extent, Extent, Extent] = (0.04, 0.04, 0.04)
    jitter: float = Field(0.0, ge=0.0, le=0.2, description="metres, uniform in x and y")
    spare: bool = False
    #: Each a value, or a list of values to draw one from per episode.
    attributes: dict[
        AttributeName, AttributeValue | Annotated[list[AttributeValue], Field(min_length=1)]
    ] = Field(default_factory=dict, max_length=16)

    @field_validator("attributes")
    @classmethod
    def _not_reserved(cls, attributes: dict[str, object]) -> dict[str, object]:
        for name in RESERVED:
            if name in attributes:
                raise ValueError(f"{name}: is the object's own field, not an attribute")
        return attributes

    @model_validator(mode="after")
    def _one_position(self) -> ObjectSpec:
        if (self.position is None) == (self.positions is None):
            raise ValueError("position: give either position or positions (a list), not both")
        return self

    @property
    def anchor(self) -> Position:
        """Where the object stands without randomization (its first listed position)."""
        if self.position is not None:
            return self.position
        assert self.positions is not None
        return self.positions[0]


class GoalSpec(_Strict):
    id: Name
    category: Literal["block", "cover"]
    position: tuple[Coordinate, Coordinate, Coordinate]
    optional: bool = False
    #: What fills it: every key must match (an attribute, ``id``, or ``size`` within 1 mm).
    accepts: dict[AttributeName, AttributeValue | tuple[Extent, Extent, Extent]] = Field(
        default_factory=dict, max_length=16
    )

    @field_validator("accepts")
    @classmethod
    def _known_forms(cls, accepts: dict[str, object]) -> dict[str, object]:
        for key, value in accepts.items():
            if key == "size" and not isinstance(value, tuple):
                raise ValueError("size: give the full extents [x, y, z], metres")
            if key == "id" and not isinstance(value, str):
                raise ValueError("id: give an object's id")
            if key != "size" and isinstance(value, tuple):
                raise ValueError(f"{key}: give one value (text or a number), not a list")
        return accepts


class ContainerSpec(_Strict):
    id: Name
    centre: tuple[Coordinate, Coordinate]
    inner: tuple[Extent, Extent]
    wall: Extent = 0.01
    height: Extent = 0.06
