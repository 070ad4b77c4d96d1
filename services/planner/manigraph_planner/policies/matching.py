"""The expert's rules for goals that say what they accept: which object to which goal, read
off the Scene alone (``--policy expert`` on any task file; docs/training.md).

A goal holds the object of its category resting nearest to it, within :data:`HOLD_DISTANCE`;
it is *done* when it accepts that object (``manigraph_shared.acceptance``). The objects
still to place are those in no done goal: loose ones, and ones in a goal that does not
accept them. They are matched to the goals not yet done (a maximum bipartite matching of
what each goal accepts, ``manigraph_shared.goal_matching``), so no object is sent to a goal
that another object is needed for:

1. **Fill**: the lowest goal that can be filled now (free, nothing over it, every goal it
   stands on done), with the highest movable object it accepts that still leaves a maximum
   matching of the rest (ties: the smaller id).
2. **Move out**: else an object sitting in a goal that does not accept it goes to a goal that
   does and can be filled now.

Objects that no goal accepts (spares, distractors) are never picked. Nothing to do
(everything done, or what is left cannot be done): no decision.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

from manigraph_planner.policies.base import Decision
from manigraph_planner.scene_geometry import SceneGeometry
from manigraph_shared.acceptance import admits
from manigraph_shared.goal_matching import as_masks, matching_size
from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneGoal, SceneObject

__all__ = ["HOLD_DISTANCE", "GoalMatching"]

#: An object whose centre is this close to a goal's (metres) rests in it.
HOLD_DISTANCE = 0.02  # the physics world's goal tolerance
#: Slack (metres) in telling which goals a goal stands on.
SUPPORT_MARGIN = 0.002
_CATEGORY = {ObjectCategory.BLOCK: GoalCategory.BLOCK, ObjectCategory.COVER: GoalCategory.COVER}


def goal_admits(goal: SceneGoal, obj: SceneObject) -> bool:
    """Its category, and every key of the goal's ``accepts``."""
    return _CATEGORY.get(obj.category) is goal.category and admits(
        goal.accepts, obj.id, obj.size.as_tuple(), obj.attributes
    )


def _height(item: SceneObject | SceneGoal) -> float:
    return round(item.position.z, 4)


@dataclass
class GoalMatching:
    """What holds what in one scene, and the expert's next block move (module docstring)."""

    scene: Scene
    geometry: SceneGeometry

    def __post_init__(self) -> None:
        self.objects = [o for o in self.scene.objects if o.visible]
        self.goals = [g for g in self.scene.goals if g.visible]
        self.holder = self._holders()
        self.done = {
            g.id for g in self.goals if g.id in self.holder and goal_admits(g, self.holder[g.id])
        }
        placed = {self.holder[g].id for g in self.done}
        self.loose = [o for o in self.objects if o.id not in placed]

    def _holders(self) -> dict[str, SceneObject]:
        held: dict[str, SceneObject] = {}
        taken: set[str] = set()
        pairs = sorted(
            (_distance(o, g), g.id, o.id, g, o)
            for g in self.goals
            for o in self.objects
            if _CATEGORY.get(o.category) is g.category
        )
        for distance, _, _, goal, obj in pairs:
            if distance > HOLD_DISTANCE:
                break
            if goal.id not in held and obj.id not in taken:
                held[goal.id] = obj
                taken.add(obj.id)
        return held

    def supports(self, goal: SceneGoal) -> list[SceneGoal]:
        """The goals ``goal`` stands on: its category's, one object height lower, footprints
        overlapping (a stack: the one under it; a pyramid: the two; the table: none)."""
        sizes = [o.size for o in self.objects if _CATEGORY.get(o.category) is goal.category]
        if not sizes:
            return []
        reach_x = max(s.x for s in sizes) - SUPPORT_MARGIN
        reach_y = max(s.y for s in sizes) - SUPPORT_MARGIN
        tallest = max(s.z for s in sizes) + SUPPORT_MARGIN
        shortest = min(s.z for s in sizes) - SUPPORT_MARGIN
        return [
            other
            for other in self.goals
            if other.category is goal.category
            and shortest <= goal.position.z - other.position.z <= tallest
            and abs(goal.position.x - other.position.x) < reach_x
            and abs(goal.position.y - other.position.y) < reach_y
        ]

    def fillable(self, goal: SceneGoal) -> bool:
        """Free, nothing over it, and every goal under it done."""
        return (
            goal.id not in self.holder
            and not goal.filled
            and not self.geometry.is_blocked(goal)
            and all(s.id in self.done for s in self.supports(goal))
        )

    def open_goals(self) -> list[SceneGoal]:
        """Block goals not done, lowest first (ties: the smaller id)."""
        goals = [
            g for g in self.goals if g.category is GoalCategory.BLOCK and g.id not in self.done
        ]
        return sorted(goals, key=lambda g: (_height(g), g.id))

    def to_place(self) -> list[SceneObject]:
        """Blocks in no done goal that some open goal accepts, highest first."""
        goals = self.open_goals()
        blocks = [
            o
            for o in self.loose
            if o.category is ObjectCategory.BLOCK and any(goal_admits(g, o) for g in goals)
        ]
        return sorted(blocks, key=lambda o: (-_height(o), o.id))

    def first_move(self) -> Decision | None:
        """The expert's decision: the first of :meth:`moves`, the rest never computed."""
        return next(self.moves(), None)

    def ranked_moves(self) -> list[Decision]:
        """Every fill (rule 1), in the expert's order, then every move-out (rule 2)."""
        return list(self.moves())

    def moves(self) -> Iterator[Decision]:
        """Rule 1's fills in the expert's order, then rule 2's move-outs, each once."""
        goals, blocks = self.open_goals(), self.to_place()
        admitted = [[j for j, o in enumerate(blocks) if goal_admits(g, o)] for g in goals]
        fillable = [self.fillable(g) for g in goals]
        rows = as_masks(admitted)
        best = matching_size(rows)
        fills: set[Decision] = set()
        for row, goal in enumerate(goals):
            if not fillable[row]:
                continue
            rest = rows[:row] + rows[row + 1 :]
            for j in admitted[row]:
                block = blocks[j]
                if self.geometry.is_covered(block):
                    continue
                if matching_size(rest, banned=j) == best - 1:
                    fills.add(Decision(block.id, goal.id))
                    yield Decision(block.id, goal.id)
        wrong = {self.holder[g.id].id for g in goals if g.id in self.holder}
        for block in blocks:
            if block.id not in wrong or self.geometry.is_covered(block):
                continue
            for row, goal in enumerate(goals):
                move = Decision(block.id, goal.id)
                if fillable[row] and goal_admits(goal, block) and move not in fills:
                    yield move


def _distance(obj: SceneObject, goal: SceneGoal) -> float:
    a, b = obj.position, goal.position
    return math.sqrt((a.x - b.x) ** 2 + (a.y - b.y) ** 2 + (a.z - b.z) ** 2)
