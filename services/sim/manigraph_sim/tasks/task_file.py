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
(``goals.0.position.2: ...``).
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
        return self


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
            field = ".".join(str(part) for part in error["loc"]) or "<file>"
            problems.append(f"{field}: {error['msg'].removeprefix('Value error, ')}")
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
