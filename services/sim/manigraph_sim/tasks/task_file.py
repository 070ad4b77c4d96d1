"""User-described layouts: a TOML task file, validated, becomes a task like any other.

```toml
name = "two blocks"                 # optional
randomize_xy = 0.05                 # metres: the whole layout shifts by up to this, per seed
partially_observable = false        # hide what is in a closed container until it is opened

[[objects]]                         # category: block | cover
id = "block_0"
category = "block"
position = [0.50, -0.10, 0.02]      # centre, metres, robot frame
size = [0.04, 0.04, 0.04]           # full extents, metres

[[goals]]                           # category: block | cover (what fills it)
id = "goal_0"
category = "block"
position = [0.45, 0.15, 0.02]
optional = false                    # optional goals (cover storage) need not be filled

[[containers]]                      # static open-top boxes
id = "box_0"
centre = [0.5, 0.2]
inner = [0.14, 0.14]
wall = 0.01
height = 0.06
```

A syntax error names the line and column; a bad value names the field
(``goals.0.position.2: ...``). Layouts that cannot happen are refused too, naming the object
or goal: objects that overlap one another, objects below the table, objects or goals outside
the robot's reach (``REACH``, the skills' default workspace, after ``randomize_xy``), block
goals closer than a block's width, and more required block (cover) goals than blocks (covers).
"""

from __future__ import annotations

import tomllib
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from manigraph_shared.errors import TaskError
from manigraph_sim.tasks.base import Task, TaskParams
from manigraph_sim.world_model import Body, Container, Goal, Layout

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


class ObjectSpec(_Strict):
    id: Name
    category: Literal["block", "cover"]
    position: tuple[Coordinate, Coordinate, Coordinate]
    size: tuple[Extent, Extent, Extent] = (0.04, 0.04, 0.04)


class GoalSpec(_Strict):
    id: Name
    category: Literal["block", "cover"]
    position: tuple[Coordinate, Coordinate, Coordinate]
    optional: bool = False


class ContainerSpec(_Strict):
    id: Name
    centre: tuple[Coordinate, Coordinate]
    inner: tuple[Extent, Extent]
    wall: Extent = 0.01
    height: Extent = 0.06


class TaskFile(_Strict):
    name: str = Field("task file", max_length=128)
    randomize_xy: float = Field(0.0, ge=0.0, le=0.5)
    partially_observable: bool = False
    objects: list[ObjectSpec] = Field(min_length=1, max_length=256)
    goals: list[GoalSpec] = Field(min_length=1, max_length=256)
    containers: list[ContainerSpec] = Field(default_factory=list, max_length=16)

    @model_validator(mode="after")
    def _consistent(self) -> TaskFile:
        names = [o.id for o in self.objects] + [g.id for g in self.goals]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"id: used twice: {', '.join(duplicates)}")
        if all(goal.optional for goal in self.goals):
            raise ValueError("goals: at least one goal must not be optional")
        problems = [
            *self._outside_reach(),
            *self._overlapping_objects(),
            *self._crowded_block_goals(),
            *self._too_many_goals(),
        ]
        if problems:
            shown = problems[:MAX_PROBLEMS_NAMED]
            more = len(problems) - len(shown)
            raise ValueError("; ".join(shown) + (f"; and {more} more" if more else ""))
        return self

    def _outside_reach(self) -> list[str]:
        margin = (self.randomize_xy, self.randomize_xy, 0.0)
        places = [(f"objects.{i}", o.id, o.position) for i, o in enumerate(self.objects)]
        places += [(f"goals.{i}", g.id, g.position) for i, g in enumerate(self.goals)]
        problems = []
        for field, name, position in places:
            for axis, (value, (low, high), shift) in enumerate(
                zip(position, REACH, margin, strict=True)
            ):
                if not (low <= value - shift and value + shift <= high):
                    problems.append(
                        f"{field}.position.{axis}: {name} at {value:g} m is outside the "
                        f"robot's reach [{low:g}, {high:g}]"
                        + (f" (with randomize_xy {shift:g})" if shift else "")
                    )
        for i, o in enumerate(self.objects):
            bottom = o.position[2] - o.size[2] / 2
            if bottom < -OVERLAP_TOLERANCE:
                problems.append(
                    f"objects.{i}.position.2: {o.id} reaches {-bottom:g} m below the table"
                )
        return problems

    def _overlapping_objects(self) -> list[str]:
        problems = []
        for i, a in enumerate(self.objects):
            for j in range(i + 1, len(self.objects)):
                b = self.objects[j]
                depth = min(
                    (sa + sb) / 2 - abs(pa - pb)
                    for pa, pb, sa, sb in zip(a.position, b.position, a.size, b.size, strict=True)
                )
                if depth > OVERLAP_TOLERANCE:
                    problems.append(
                        f"objects.{j}: {b.id} overlaps objects.{i} ({a.id}) by {depth * 100:.1f} cm"
                    )
        return problems

    def _crowded_block_goals(self) -> list[str]:
        blocks = [(i, g) for i, g in enumerate(self.goals) if g.category == "block"]
        problems = []
        for n, (i, a) in enumerate(blocks):
            for j, b in blocks[n + 1 :]:
                gap = max(abs(pa - pb) for pa, pb in zip(a.position, b.position, strict=True))
                if gap < BLOCK_WIDTH - OVERLAP_TOLERANCE:
                    problems.append(
                        f"goals.{j}: {b.id} is {gap * 100:.1f} cm from goals.{i} ({a.id}); "
                        f"two blocks need {BLOCK_WIDTH * 100:.0f} cm"
                    )
        return problems

    def _too_many_goals(self) -> list[str]:
        problems = []
        for category in ("block", "cover"):
            have = sum(o.category == category for o in self.objects)
            need = sum(g.category == category and not g.optional for g in self.goals)
            if need > have:
                problems.append(
                    f"goals: {need} required {category} goals but only {have} "
                    f"{category}{'s' if have != 1 else ''} in objects"
                )
        return problems


def parse_task_file(text: str) -> TaskFile:
    """Validate a task file's text; ``TaskError`` names the line or the field."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise TaskError(f"task file: {exc}") from None
    try:
        return TaskFile.model_validate(data)
    except ValidationError as exc:
        problems = []
        for error in exc.errors(include_url=False):
            field = ".".join(str(part) for part in error["loc"])
            message = error["msg"].removeprefix("Value error, ")
            # Whole-file checks name their own fields ("objects.1: red overlaps ...").
            problems.append(f"{field}: {message}" if field else message)
        raise TaskError("task file: " + "; ".join(problems)) from None


class FileTask(Task):
    """A layout from a task file.

    **Randomizations**: the whole layout moves by up to ``randomize_xy`` in x and y, seeded.

    **Success Conditions**: every goal not marked ``optional`` holds an object of its category.
    """

    name = "file"

    def __init__(self, spec: TaskFile) -> None:
        self.spec = spec
        super().__init__(TaskParams(blocks=sum(o.category == "block" for o in spec.objects)))

    def layout(self, rng: np.random.Generator) -> Layout:
        r = self.spec.randomize_xy
        shift = np.array([*rng.uniform(-r, r, 2), 0.0]) if r > 0 else np.zeros(3)
        bodies = [
            Body(o.id, o.category, np.array(o.size), np.array(o.position) + shift)
            for o in self.spec.objects
        ]
        goals = [Goal(g.id, g.category, np.array(g.position) + shift) for g in self.spec.goals]
        containers = [
            Container(c.id, np.array(c.centre) + shift[:2], np.array(c.inner), c.wall, c.height)
            for c in self.spec.containers
        ]
        optional = {g.id for g in self.spec.goals if g.optional}
        return Layout(bodies, goals, containers, optional, self.spec.partially_observable)
