"""User-described layouts: a TOML task file, validated, becomes a task like any other.

```toml
name = "two blocks"                 # optional
randomize_xy = 0.05                 # metres: the whole layout shifts by up to this, per seed
partially_observable = false        # hide what is in a closed container until it is opened
shuffle = ["colour"]                # per seed: permute these attributes among their objects

[[objects]]                         # category: block | cover
id = "block_0"
category = "block"
position = [0.50, -0.10, 0.02]      # centre, metres, robot frame
size = [0.04, 0.04, 0.04]           # full extents, metres
jitter = 0.01                       # metres: this object shifts by up to this in x, y, per seed
attributes = { colour = "red", label = "bolt" }  # text or numbers, what goals tell apart

[[objects]]
id = "block_1"
category = "block"
positions = [[0.40, -0.20, 0.02], [0.60, -0.20, 0.02]]  # one of these, chosen per seed
spare = true                        # belongs to no goal: the goals are filled without it
attributes = { colour = ["red", "blue"] }        # a list: one value drawn per seed

[[goals]]                           # category: block | cover (what fills it)
id = "goal_0"
category = "block"
position = [0.45, 0.15, 0.02]
optional = false                    # optional goals (cover storage) need not be filled
accepts = { colour = "red" }        # what fills it: every key must match (below)

[[containers]]                      # static open-top boxes
id = "box_0"
centre = [0.5, 0.2]
inner = [0.14, 0.14]
wall = 0.01
height = 0.06
```

An object gives ``position`` or ``positions`` (not both). An object listed directly above
another one (same x, y within 1 mm, higher) rests on it and moves with it, so a tower jitters
as one; its own ``jitter`` and ``positions`` are refused. Objects choosing among listed
positions never take one another's place (a draw that cannot avoid it is refused, naming the
object). Every required goal needs an object of its category that is not a spare.

**Attributes and accepts.** An object's ``attributes`` (names: lower case, ``[a-z0-9_]``; values:
text or numbers; ``id`` and ``size`` are the object's own fields) say what tells it apart. A
goal's ``accepts`` says what fills it, and every key listed must match: an attribute's value
(``{ colour = "red" }``, ``{ label = "bolt" }``; numbers within 1e-9), the object itself
(``{ id = "part_2" }``), or its full extents (``{ size = [0.03, 0.03, 0.03] }``, within 1 mm
on each axis). A goal without ``accepts`` takes any object of its category. A goal holding an
object it does not accept is not filled (the episode's end event counts it as a wrong object).

**Drawing per episode**, from the seed, after the positions (a file without draws keeps its
layouts): a list value draws one of its values; then each attribute named in ``shuffle`` has
its values permuted among the objects that carry it. A file whose required goals cannot all
be filled at once by its objects that are not spares (a bipartite matching, each object
filling one goal), whatever the draws give, is refused naming the goal; a draw that leaves a
goal without an object it accepts is drawn again, up to 100 times.

A syntax error names the line and column; a bad value names its line and the field
(``line 9: goals.0.position.2: ...``), and a key that is no field suggests the one it was
probably meant to be (``line 9: objects.1.postion: Extra inputs are not permitted; did you
mean position?``). A file nested too deeply to read (``x = [[[...]]]``, thousands deep) is
refused in one line. Layouts that cannot happen are refused too, naming the object
or goal: objects that overlap one another, objects below the table, objects or goals outside
the robot's reach (``REACH``, the skills' default workspace, after ``randomize_xy``), block
goals closer than a block's width, and more required block (cover) goals than blocks (covers).
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from functools import cached_property, lru_cache
from typing import Protocol

import numpy as np
from pydantic import BaseModel, Field, ValidationError, model_validator

from manigraph_blocks.sim import task_attributes
from manigraph_blocks.sim.options import BlockOptions, BlockTask
from manigraph_blocks.sim.task_file_errors import describe_errors
from manigraph_blocks.sim.task_file_specs import (
    BLOCK_WIDTH,
    MAX_PROBLEMS_NAMED,
    OVERLAP_TOLERANCE,
    REACH,
    AttributeName,
    ContainerSpec,
    GoalSpec,
    ObjectSpec,
    Position,
    _Strict,
)
from manigraph_shared.errors import TaskError
from manigraph_shared.printable import printable
from manigraph_sim.world_model import Body, Container, Goal, Judge, Layout


class Rules(Protocol):
    """The judge's rules of an episode (``rules_file.Rules``)."""

    def judge(self, layout: Layout) -> Judge: ...


class TaskFile(_Strict):
    name: str = Field("task file", max_length=128)
    randomize_xy: float = Field(0.0, ge=0.0, le=0.5)
    partially_observable: bool = False
    objects: list[ObjectSpec] = Field(min_length=1, max_length=256)
    goals: list[GoalSpec] = Field(min_length=1, max_length=256)
    containers: list[ContainerSpec] = Field(default_factory=list, max_length=16)
    #: Attributes whose values are permuted among the objects carrying them, per episode.
    shuffle: list[AttributeName] = Field(default_factory=list, max_length=16)
    #: Attributes a goal carrying them matches: it accepts only objects of its own value.
    same: list[AttributeName] = Field(default_factory=list, max_length=16)

    @model_validator(mode="after")
    def _consistent(self) -> TaskFile:
        names = [o.id for o in self.objects] + [g.id for g in self.goals]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"id: used twice: {', '.join(duplicates)}")
        if all(goal.optional for goal in self.goals):
            raise ValueError("goals: at least one goal must not be optional")
        for index, item in enumerate(self.objects):
            base = self.support_of(index)
            if base is not None and (item.jitter > 0 or item.positions is not None):
                raise ValueError(
                    f"objects.{index}: rests on {self.objects[base].id} and moves with it; "
                    "give it neither jitter nor positions"
                )
        problems = [
            *self._outside_reach(),
            *self._overlapping_objects(),
            *self._crowded_block_goals(),
            *self._too_many_goals(),
            *self._unknown_attributes(),
        ]
        if not problems:
            problems = self._unsatisfiable()
        if problems:
            shown = problems[:MAX_PROBLEMS_NAMED]
            more = len(problems) - len(shown)
            raise ValueError("; ".join(shown) + (f"; and {more} more" if more else ""))
        return self

    def _outside_reach(self) -> list[str]:
        places = [
            (f"objects.{i}", o.id, position, jitter)
            for i, o in enumerate(self.objects)
            for position, jitter in self.placements(i)
        ]
        places += [(f"goals.{i}", g.id, g.position, 0.0) for i, g in enumerate(self.goals)]
        problems = []
        for field, name, position, jitter in places:
            shift_xy = self.randomize_xy + jitter
            margin = (shift_xy, shift_xy, 0.0)
            for axis, (value, (low, high), shift) in enumerate(
                zip(position, REACH, margin, strict=True)
            ):
                if not (low <= value - shift and value + shift <= high):
                    problems.append(
                        f"{field}.position.{axis}: {name} at {value:g} m is outside the "
                        f"robot's reach [{low:g}, {high:g}]"
                        + (f" (with randomize_xy and jitter {shift:g})" if shift else "")
                    )
        for i, o in enumerate(self.objects):
            bottom = o.anchor[2] - o.size[2] / 2
            if bottom < -OVERLAP_TOLERANCE:
                problems.append(
                    f"objects.{i}.position.2: {o.id} reaches {-bottom:g} m below the table"
                )
        return problems

    def _overlapping_objects(self) -> list[str]:
        """Objects that overlap in some draw (jitter at its worst; two objects choosing the
        same listed position never both take it). Each pair's placements are compared as
        arrays: 40 objects with 64 listed positions each are 3 million placement pairs."""
        places = [np.array([p for p, _ in self.placements(i)]) for i in range(len(self.objects))]
        bases = [  # each placement as the position its tower's bottom object takes
            places[i] - np.array(o.anchor) + np.array(self.objects[self.root_of(i)].anchor)
            for i, o in enumerate(self.objects)
        ]
        problems = []
        for i, a in enumerate(self.objects):
            for j in range(i + 1, len(self.objects)):
                b = self.objects[j]
                depth = self._deepest(i, j, places, bases)
                if depth > OVERLAP_TOLERANCE:
                    problems.append(
                        f"objects.{j}: {b.id} overlaps objects.{i} ({a.id}) by {depth * 100:.1f} cm"
                    )
        return problems

    def _deepest(self, i: int, j: int, places: list[np.ndarray], bases: list[np.ndarray]) -> float:
        """The deepest overlap of objects ``i`` and ``j`` over their placements (0: none)."""
        slack = self.placements(i)[0][1] + self.placements(j)[0][1]
        margins = np.array([slack, slack, 0.0])
        half = (np.array(self.objects[i].size) + np.array(self.objects[j].size)) / 2
        gap = np.abs(places[i][:, None, :] - places[j][None, :, :])
        depth = (half - np.maximum(0.0, gap - margins)).min(axis=2)
        ri, rj = self.root_of(i), self.root_of(j)
        listed = self.objects[ri].positions is not None and self.objects[rj].positions is not None
        if ri != rj and listed:  # both cannot take the same listed position
            same = np.abs(bases[i][:, None, :] - bases[j][None, :, :]).max(axis=2) < 1e-3
            depth = np.where(same, -np.inf, depth)
        return max(0.0, float(depth.max()))

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
            have = sum(o.category == category and not o.spare for o in self.objects)
            need = sum(g.category == category and not g.optional for g in self.goals)
            if need > have:
                problems.append(
                    f"goals: {need} required {category} goals but only {have} "
                    f"{category}{'s' if have != 1 else ''} in objects that are not spares"
                )
        return problems

    def _unknown_attributes(self) -> list[str]:
        return [
            *task_attributes.unknown_attributes(self.objects, self.goals, self.shuffle),
            *task_attributes.unknown_same(self.objects, self.goals, self.same, "same"),
        ]

    def _unsatisfiable(self) -> list[str]:
        """The first required goal the objects that are not spares cannot fill while the
        others are filled, whatever the draws give (a bipartite matching)."""
        missing = task_attributes.first_shortfall(self.required, self.candidates)
        return [] if missing is None else [missing[1]]

    @property
    def required(self) -> list[task_attributes.Wanted]:
        """The goals that must be filled, as the matching sees them."""
        return task_attributes.required(self.goals, self.same, shuffle=self.shuffle)

    @property
    def candidates(self) -> list[task_attributes.Candidate]:
        """The objects as the matching sees them, each attribute with every value a draw may
        give it."""
        return task_attributes.candidates(self.objects, self.shuffle)

    def support_of(self, index: int) -> int | None:
        """The object that object ``index`` rests on (same x, y within 1 mm, the highest one
        below it), or None when it stands on the table."""
        return self._supports[index]

    @cached_property
    def _supports(self) -> list[int | None]:
        """Every object's support, found once: the checks ask for towers per pair of objects,
        and scanning all objects each time made a 256-object file cost O(n^3)-O(n^4) (a 64 KiB
        task file of overlapping blocks kept the sim busy for minutes)."""
        anchors = [o.anchor for o in self.objects]
        supports: list[int | None] = []
        for index, (x, y, z) in enumerate(anchors):
            below = [
                (other[2], j)
                for j, other in enumerate(anchors)
                if j != index
                and abs(other[0] - x) < 1e-3
                and abs(other[1] - y) < 1e-3
                and other[2] < z
            ]
            supports.append(max(below)[1] if below else None)
        return supports

    @property
    def blocks(self) -> int:
        """Blocks in the file, spares included."""
        return sum(o.category == "block" for o in self.objects)

    def root_of(self, index: int) -> int:
        """The object at the bottom of the tower that object ``index`` belongs to."""
        return self._roots[index]

    @cached_property
    def _roots(self) -> list[int]:
        roots: list[int] = []
        for index in range(len(self.objects)):
            root = index
            while (base := self._supports[root]) is not None:  # supports lie strictly lower
                root = base
            roots.append(root)
        return roots

    def placements(self, index: int) -> list[tuple[Position, float]]:
        """Where object ``index`` may stand before the whole-layout shift: each listed position
        of its tower's bottom object, moved as the tower moves, with that object's jitter."""
        return self._placements[index]

    @cached_property
    def _placements(self) -> list[list[tuple[Position, float]]]:
        return [self._placements_of(index) for index in range(len(self.objects))]

    def _placements_of(self, index: int) -> list[tuple[Position, float]]:
        root = self.objects[self.root_of(index)]
        offset = [a - b for a, b in zip(self.objects[index].anchor, root.anchor, strict=True)]
        bases = root.positions if root.positions is not None else [root.anchor]
        return [
            (
                (base[0] + offset[0], base[1] + offset[1], base[2] + offset[2]),
                root.jitter,
            )
            for base in bases
        ]


def parse_task_file(text: str, source: str | None = None) -> TaskFile:
    """Validate a task file's text; ``TaskError`` names the line or the field. ``source``
    (the file's path) names the file in the error; without it, "task file". The message is
    :func:`printable`: the file's text it quotes never reaches a terminal as control codes.

    The last few files' outcomes are kept: the sim checks a file where a reset arrives, off
    its own thread, and its thread then lays the same text out without checking it again."""
    parsed = _parsed(text, source)
    if isinstance(parsed, str):
        raise TaskError(parsed)
    return parsed


@lru_cache(maxsize=8)
def _parsed(text: str, source: str | None) -> TaskFile | str:
    """The file, or why it is refused (a message, so that a refusal is kept too)."""
    prefix = f"task file {source}" if source else "task file"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        return printable(f"{prefix}: {exc}")
    except RecursionError:
        return printable(f"{prefix}: {NESTED_TOO_DEEPLY}")
    try:
        return TaskFile.model_validate(data)
    except ValidationError as exc:
        tables: dict[str, type[BaseModel]] = {
            "objects": ObjectSpec,
            "goals": GoalSpec,
            "containers": ContainerSpec,
        }
        problems = describe_errors(exc.errors(include_url=False), text, TaskFile, tables)
        return printable(f"{prefix}: " + "; ".join(problems))
    except RecursionError:
        return printable(f"{prefix}: {NESTED_TOO_DEEPLY}")


#: Why a file of arrays or tables nested thousands deep is refused (Python's parser recurses).
NESTED_TOO_DEEPLY = "arrays or tables nested too deeply to read (a task file needs a few levels)"


def _accepts(
    accepts: Mapping[str, str | float | Sequence[float]],
) -> dict[str, str | float | list[float]]:
    return {k: v if isinstance(v, str | int | float) else list(v) for k, v in accepts.items()}


class FileTask(BlockTask):
    """A layout from a task file.

    **Randomizations** (all seeded by the episode seed): each object stands at one of its
    listed ``positions`` (no two on the same one) and moves by up to its ``jitter`` in x and y;
    objects resting on it move with it; then the whole layout moves by up to ``randomize_xy``.

    Then each object's attributes are drawn: one value of each list, then each ``shuffle``d
    attribute permuted among the objects carrying it; a draw that leaves a required goal
    without an object it accepts is drawn again (``task_attributes.MAX_DRAWS`` times).

    **Success Conditions**: every goal not marked ``optional`` holds an object of its category
    that it accepts (every key of its ``accepts``), on filled goals.
    """

    name = "file"

    def __init__(self, spec: TaskFile, rules: Rules | None = None) -> None:
        self.spec = spec
        #: The judge's rules (an ``EpisodeRequest``'s ``rules``): never in the layout's goals.
        self.rules = rules
        super().__init__(BlockOptions(blocks=spec.blocks))

    def layout(self, rng: np.random.Generator) -> Layout:
        r = self.spec.randomize_xy
        shift = np.array([*rng.uniform(-r, r, 2), 0.0]) if r > 0 else np.zeros(3)
        positions = self._positions(rng)
        spec = self.spec
        drawn, drawn_goals = task_attributes.episode_attributes(
            rng, spec.objects, spec.goals, spec.shuffle, spec.same
        )
        bodies = [
            Body(o.id, o.category, np.array(o.size), position + shift, attributes)
            for o, position, attributes in zip(spec.objects, positions, drawn, strict=True)
        ]
        goals = [
            Goal(
                g.id,
                g.category,
                np.array(g.position) + shift,
                _accepts(task_attributes.same_accepts(g.accepts, own, spec.same)),
                own,
            )
            for g, own in zip(spec.goals, drawn_goals, strict=True)
        ]
        containers = [
            Container(c.id, np.array(c.centre) + shift[:2], np.array(c.inner), c.wall, c.height)
            for c in self.spec.containers
        ]
        optional = {g.id for g in self.spec.goals if g.optional}
        layout = Layout(bodies, goals, containers, optional, self.spec.partially_observable)
        if self.rules is not None:
            layout.judge = self.rules.judge(layout)
        return layout

    def _positions(self, rng: np.random.Generator) -> list[np.ndarray]:
        """Each object's drawn position before the whole-layout shift: its listed choice (none
        taken twice, nor where a fixed object stands) plus its jitter; objects resting on
        another move with it."""
        objects = self.spec.objects
        offsets = [np.zeros(3) for _ in objects]
        taken = [np.array(o.anchor) for o in objects if o.positions is None]
        for index, item in enumerate(objects):
            if self.spec.support_of(index) is not None:
                continue
            if item.positions is not None:
                free = [
                    np.array(p)
                    for p in item.positions
                    if all(np.abs(np.array(p) - t).max() > 1e-3 for t in taken)
                ]
                if not free:
                    raise TaskError(
                        f"task file: objects.{index}.positions: every listed position is taken "
                        "by another object in this draw; list more"
                    )
                choice = free[int(rng.integers(len(free)))]
                taken.append(choice)
                offsets[index] = choice - np.array(item.anchor)
            if item.jitter > 0:
                offsets[index][:2] += rng.uniform(-item.jitter, item.jitter, 2)
        return [np.array(o.anchor) + self._offset(i, offsets) for i, o in enumerate(objects)]

    def _offset(self, index: int, offsets: list[np.ndarray]) -> np.ndarray:
        base = self.spec.support_of(index)
        return offsets[index] if base is None else self._offset(base, offsets)
