"""The size-sort task's expert: the nearest block that fits a free goal, to that goal.

The toy third task (issue 31; docs/tasks/size-sort.md): everything it brings to the planner
is this module and its import in ``policies/__init__.py``. No new node feature is needed: a
goal on a bin's floor is where a block's centre should be, half the block's side up, so which
blocks fit which goals is the node heights (``z``) the GNN already sees.
"""

from __future__ import annotations

import math

from manigraph_planner.policies.base import TASK_EXPERTS, Decision, Policy, register_policy
from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneGoal, SceneObject

#: A block fits a goal when resting on the goal's floor puts its centre this close (metres)
#: to the goal's: the task's sizes differ by 2 cm in centre height.
FIT = 0.005


def fits(block: SceneObject, goal: SceneGoal) -> bool:
    """Whether ``block``, resting on the floor under ``goal``, has its centre at the goal."""
    return abs(block.size.z / 2 - goal.position.z) <= FIT


def _distance(block: SceneObject, goal: SceneGoal) -> float:
    a, b = block.position, goal.position
    return math.hypot(a.x - b.x, a.y - b.y)


@register_policy("size-sort-expert")
class SizeSortExpert(Policy):
    """Of every block still loose and every free goal it fits, the pair nearest in x and y
    (ties: the smaller block id, then goal id). The order is one a GNN can read off positions
    alone; which free goal of a bin a block takes does not matter for success."""

    def ranked(self, scene: Scene) -> list[Decision]:
        """Every fitting pair, nearest first: what a planner tries when the first made no
        progress."""
        blocks = [
            o
            for o in scene.objects
            if o.visible and o.category is ObjectCategory.BLOCK and not o.filled
        ]
        goals = [
            g
            for g in scene.goals
            if g.visible and g.category is GoalCategory.BLOCK and not g.filled
        ]
        pairs = [(b, g) for b in blocks for g in goals if fits(b, g)]
        pairs.sort(key=lambda pair: (round(_distance(*pair), 6), pair[0].id, pair[1].id))
        return [Decision(b.id, g.id) for b, g in pairs]

    def decide(self, scene: Scene) -> Decision | None:
        ranked = self.ranked(scene)
        return ranked[0] if ranked else None


TASK_EXPERTS.add("size-sort", SizeSortExpert, help="the nearest fitting block to its goal")
