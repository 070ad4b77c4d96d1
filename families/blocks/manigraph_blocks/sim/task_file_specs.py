"""The task file's tables as validated records: an object, a goal, a container, and the value
types and robot-reach bounds they are checked against (``families.blocks.task_file`` reads the
file and checks the layout as a whole)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, PlainValidator, field_validator, model_validator

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


#: The contract's attribute names and values (``manigraph_shared.messages.scene``): text of
#: 1-64 characters or a number within +-1e6; a list draws one per episode (at most 64).
AttributeName = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]{0,31}$")]
MAX_LISTED_VALUES = 64


def attribute_value(value: object) -> str | float:
    """One attribute value, checked as the contract will check it (one clear message, where a
    union of types would give one per type)."""
    if isinstance(value, str):
        if not 1 <= len(value) <= 64:
            raise ValueError("text values have 1 to 64 characters")
        return value
    if isinstance(value, int | float) and not isinstance(value, bool):
        if not abs(value) <= 1e6:  # NaN fails too
            raise ValueError("numbers lie within -1e6 to 1e6")
        return float(value)
    raise ValueError("give text or a number (true and false are not attribute values)")


def listed_values(value: object) -> str | float | list[str | float]:
    """An object's attribute: one value, or a list of values to draw one from."""
    if isinstance(value, list):
        if not 1 <= len(value) <= MAX_LISTED_VALUES:
            raise ValueError(f"a list of values holds 1 to {MAX_LISTED_VALUES}")
        return [attribute_value(v) for v in value]
    return attribute_value(value)


def accepted_value(value: object) -> str | float | tuple[float, float, float]:
    """What a goal accepts under one key: a value, or full extents (for ``size``)."""
    if isinstance(value, list):
        if len(value) != 3 or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and 0 < v <= 2 for v in value
        ):
            raise ValueError(
                "a list is only for size = [x, y, z] (full extents, each in (0, 2] metres); "
                "other keys take one value"
            )
        return (float(value[0]), float(value[1]), float(value[2]))
    return attribute_value(value)


ListedValue = Annotated[str | float | list[str | float], PlainValidator(listed_values)]
AcceptedValue = Annotated[str | float | tuple[float, float, float], PlainValidator(accepted_value)]
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
    attributes: dict[AttributeName, ListedValue] = Field(default_factory=dict, max_length=16)

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
    accepts: dict[AttributeName, AcceptedValue] = Field(default_factory=dict, max_length=16)
    #: What tells goals apart (a bin's colour): each a value, or a list to draw one from.
    attributes: dict[AttributeName, ListedValue] = Field(default_factory=dict, max_length=16)

    @field_validator("attributes")
    @classmethod
    def _not_reserved(cls, attributes: dict[str, object]) -> dict[str, object]:
        for name in RESERVED:
            if name in attributes:
                raise ValueError(f"{name}: is the goal's own field, not an attribute")
        return attributes

    @field_validator("accepts")
    @classmethod
    def _known_forms(cls, accepts: dict[str, object]) -> dict[str, object]:
        return known_accept_forms(accepts)


def known_accept_forms(accepts: dict[str, object]) -> dict[str, object]:
    """``size`` takes extents, ``id`` an object's id, any other key one value."""
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
