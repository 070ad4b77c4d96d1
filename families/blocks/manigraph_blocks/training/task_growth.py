"""Task-file demonstrations grown past their size: more of the expert's own pairs (issue #49).

A task file's rule (which object to which goal) may be one that nobody wrote: the goals
accept anything and only the demonstrator knows that red goes left. The learner then has
no rule to augment by, so this step only repeats what the demonstration itself shows to be
right, in a scene with more objects and goals than were demonstrated:

* **the decided pair again** (``pairs`` copies): a copy of the expert's object, loose, moved
  across the table, and a copy of the expert's goal, free, beside it (within a third of the
  distance to its nearest goal, so it stays in its row, bin or side). Whatever the rule, the
  copied object belongs in the copied goal as the original does, and the expert, who chose
  that kind of pair first, still would: the label is kept;
* **finished pairs again** (``finished`` copies): a filled goal and the object resting in it,
  copied together the same way. The expert never looks at done goals.
* **taller towers**: where the finished goal is a level of a tower (goals stacked in one
  column), its copy goes into that tower instead, half the time each way:

  - *a free level on top*, a copy of its object loose on the table (beside a loose object,
    at the tower base's height), not its turn yet. Where the finished level states what it
    accepts (written rules), that level is copied: a red level over the next one once the
    red bottom is done, the 6-level ``r, g, b, r, g, b`` tower, and its accepts columns say
    which object it takes. Where it states nothing (a rule nobody wrote), the decided level
    and object are copied instead: the label's object then has a twin, so whatever order
    the teacher follows among loose objects still puts it first. (Copying the finished
    level there broke a size order: a 7 cm block loose after the 7 cm level is done told
    the network that the largest loose block is not next; docs/training.md.)
  - *the level again, in place*: a filled copy right over the original, everything above it
    (goals and the objects on them) one level higher: more levels done under the next one
    than were ever demonstrated, in the same order (a size order stays an order).

  The expert still fills the lowest level that can be filled now, with the object it chose:
  the label is kept. A new level is either filled (``goal:ready`` 0, copied) or free over a
  free level (``goal:ready`` set to 0: the spec's column, given).

With four blocks demonstrated, the last blue block is always the second; grown scenes show a
blue block still loose after three, five or more are placed, so the network cannot read
"switch colours" off how many goals are filled (what broke the colour rule at 8 blocks:
docs/training.md). Copies keep every task column, so attributes and accepts travel with them.

Shapes: ``x`` is :math:`(N, F)`, objects first (the graph state's order).
"""

from __future__ import annotations

from itertools import pairwise

import torch
from torch import Tensor

__all__ = ["grow_task_graph"]

#: How far a copied object moves across the table (metres, in x and in y).
OBJECT_SHIFT = 0.12
#: A goal's copy stays within this fraction of the distance to its nearest goal.
GOAL_SHIFT_FRACTION = 1 / 3
#: Where a goal has no other goal: at most this far (metres).
LONE_GOAL_SHIFT = 0.02


def grow_task_graph(
    x: Tensor,
    num_objects: int,
    object_index: int,
    goal_index: int,
    pairs: int,
    finished: int,
    generator: torch.Generator,
    ready_column: int | None = None,
    any_columns: tuple[int, ...] = (),
) -> tuple[Tensor, int, int, int]:
    """``x`` with ``pairs`` copies of the decided pair and up to ``finished`` copies of filled
    pairs added; returns the new features, object count, goal index and object index (the
    labelled pair: the original's, moved past the added objects). ``ready_column``: the
    spec's ``goal:ready`` column, 0 on a free level grown on a tower's top; ``any_columns``:
    its ``...:any`` columns, where a goal that states what it accepts reads 0."""
    objects, goals = x[:num_objects], x[num_objects:]
    goal = goal_index - num_objects
    new_objects: list[Tensor] = []
    new_goals: list[Tensor] = []
    for _ in range(pairs):
        obj = objects[object_index].clone()
        obj[1:3] += (torch.rand(2, generator=generator) * 2 - 1) * OBJECT_SHIFT
        obj[4] = 0.0
        free = goals[goal].clone()
        free[1:3] += _beside(goals, goal, generator)
        free[4] = 0.0
        new_objects.append(obj)
        new_goals.append(free)
    columns = _tower_columns(goals)
    in_towers: list[tuple[int, int, tuple[int, ...]]] = []
    for held, holder in _finished_pairs(objects, goals)[:finished]:
        column = next((c for c in columns if held in c), None)
        if column is not None:
            in_towers.append((held, holder, column))
            continue
        shift = _beside(goals, held, generator)
        obj, done = objects[holder].clone(), goals[held].clone()
        obj[1:3] += shift
        done[1:3] += shift
        new_objects.append(obj)
        new_goals.append(done)
    if new_objects:
        objects = torch.cat([objects, torch.stack(new_objects)])
        goals = torch.cat([goals, torch.stack(new_goals)])
    for held, holder, column in in_towers:
        if float(torch.rand(1, generator=generator)) < 0.5:
            objects, goals = _insert_level(objects, goals, held, holder, column)
        else:
            written = bool(any_columns) and bool((goals[held, list(any_columns)] < 0.5).any())
            level, its = (held, holder) if written else (goal, object_index)
            objects, goals = _free_level_on_top(
                objects, goals, level, its, object_index, column, generator, ready_column
            )
    added = len(objects) - num_objects
    if not added:
        return x, num_objects, goal_index, object_index
    grown = torch.cat([objects, goals])
    # The label stays on the original pair. Moving it to a copy at random (they are equally
    # right) was tried and scored worse at 8 and 12 objects (docs/training.md).
    return grown, num_objects + added, goal_index + added, object_index


def _beside(goals: Tensor, goal: int, generator: torch.Generator) -> Tensor:
    """A random xy offset that keeps a copy of goal ``goal`` nearer it than any other goal
    (and within 6 cm): in its own row, bin or side, whatever the rule reads off those."""
    gaps = (goals[:, 1:3] - goals[goal, 1:3]).norm(dim=1)
    gaps[goal] = float("inf")
    reach = float(gaps.min()) * GOAL_SHIFT_FRACTION if len(goals) > 1 else LONE_GOAL_SHIFT
    reach = min(reach, LONE_GOAL_SHIFT * 3)
    return (torch.rand(2, generator=generator) * 2 - 1) * reach / 2**0.5


#: Goals this close in x and in y (metres) stand in one column: a tower.
COLUMN_XY = 0.01
#: An object this close in x and in y (metres) to a column stands on it.
HOLD_XY = 0.02


def _tower_columns(goals: Tensor) -> list[tuple[int, ...]]:
    """Goal rows that stand in one column at two or more heights (a tower), each sorted by
    row; a goal in no tower is in none."""
    columns: list[tuple[int, ...]] = []
    seen: set[int] = set()
    for goal in range(len(goals)):
        if goal in seen:
            continue
        gap = (goals[:, 1:3] - goals[goal, 1:3]).abs().max(dim=1).values
        members = tuple(int(g) for g in torch.nonzero(gap <= COLUMN_XY).flatten())
        seen.update(members)
        if len({round(float(goals[g, 3]), 4) for g in members}) > 1:
            columns.append(members)
    return columns


def _level_height(goals: Tensor, column: tuple[int, ...]) -> float:
    """The smallest rise between two levels of ``column``."""
    heights = sorted({round(float(goals[g, 3]), 4) for g in column})
    return min(b - a for a, b in pairwise(heights))


def _insert_level(
    objects: Tensor, goals: Tensor, held: int, holder: int, column: tuple[int, ...]
) -> tuple[Tensor, Tensor]:
    """A filled copy of level ``held`` (with ``holder``) right over it; what stands higher
    in the column, goals and objects, one level up."""
    rise = _level_height(goals, column)
    level, rest = float(goals[held, 3]), float(objects[holder, 3])
    centre = goals[held, 1:3]
    goals, objects = goals.clone(), objects.clone()
    in_column = (goals[:, 1:3] - centre).abs().max(dim=1).values <= COLUMN_XY
    goals[in_column & (goals[:, 3] > level + 1e-4), 3] += rise
    on_column = (objects[:, 1:3] - centre).abs().max(dim=1).values <= HOLD_XY
    objects[on_column & (objects[:, 3] > rest + 1e-4), 3] += rise
    done, obj = goals[held].clone(), objects[holder].clone()
    done[3] += rise
    obj[3] += rise
    return torch.cat([objects, obj[None]]), torch.cat([goals, done[None]])


def _free_level_on_top(
    objects: Tensor,
    goals: Tensor,
    level: int,
    holder: int,
    object_index: int,
    column: tuple[int, ...],
    generator: torch.Generator,
    ready_column: int | None,
) -> tuple[Tensor, Tensor]:
    """A free copy of ``level`` on top of the tower ``column``, not ready, and a loose copy
    of its object ``holder``."""
    centre = goals[column[0], 1:3]
    in_column = (goals[:, 1:3] - centre).abs().max(dim=1).values <= COLUMN_XY
    free, obj = goals[level].clone(), objects[holder].clone()
    free[1:3] = centre
    free[3] = float(goals[in_column, 3].max()) + _level_height(goals, column)
    free[4] = 0.0
    if ready_column is not None:
        free[ready_column] = 0.0
    obj[1:4] = _loose_spot(objects, object_index, float(goals[in_column, 3].min()), generator)
    obj[4] = 0.0
    return torch.cat([objects, obj[None]]), torch.cat([goals, free[None]])


def _loose_spot(
    objects: Tensor, object_index: int, base: float, generator: torch.Generator
) -> Tensor:
    """x, y, z of a new loose object: near a loose object (the decided one where none is),
    moved as a copied object is, at the tower base's height ``base``."""
    loose = [k for k in range(len(objects)) if objects[k, 4] < 0.5] or [object_index]
    near = loose[int(torch.randint(len(loose), (1,), generator=generator))]
    spot = objects[near, 1:4].clone()
    spot[:2] += (torch.rand(2, generator=generator) * 2 - 1) * OBJECT_SHIFT
    spot[2] = base
    return spot


def _finished_pairs(objects: Tensor, goals: Tensor) -> list[tuple[int, int]]:
    """(goal, object) row pairs of filled goals and the filled object nearest each."""
    found: list[tuple[int, int]] = []
    resting = [k for k in range(len(objects)) if objects[k, 4] > 0.5]
    for held in range(len(goals)):
        if goals[held, 4] < 0.5 or not resting:
            continue
        gaps = [float((objects[k, 1:4] - goals[held, 1:4]).norm()) for k in resting]
        found.append((held, resting[gaps.index(min(gaps))]))
    return found
