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

With four blocks demonstrated, the last blue block is always the second; grown scenes show a
blue block still loose after three, five or more are placed, so the network cannot read
"switch colours" off how many goals are filled (what broke the colour rule at 8 blocks:
docs/training.md). Copies keep every task column, so attributes and accepts travel with them.

Shapes: ``x`` is :math:`(N, F)`, objects first (the graph state's order).
"""

from __future__ import annotations

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
) -> tuple[Tensor, int, int, int]:
    """``x`` with ``pairs`` copies of the decided pair and up to ``finished`` copies of filled
    pairs added; returns the new features, object count, goal index and object index (the
    labelled pair: the original's, moved past the added objects)."""
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
    for held, holder in _finished_pairs(objects, goals)[:finished]:
        shift = _beside(goals, held, generator)
        obj, done = objects[holder].clone(), goals[held].clone()
        obj[1:3] += shift
        done[1:3] += shift
        new_objects.append(obj)
        new_goals.append(done)
    if not new_objects:
        return x, num_objects, goal_index, object_index
    grown = torch.cat([objects, torch.stack(new_objects), goals, torch.stack(new_goals)])
    added = len(new_objects)
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
