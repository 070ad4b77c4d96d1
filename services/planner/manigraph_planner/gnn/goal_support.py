"""Which goals can be filled now: a tower's next level, read off the Scene (issue #49).

A goal *stands on* the goals of its category one object height lower whose footprints overlap
it (a stack: the one under it; a pyramid: the two; the table: none), as the generic expert
reads it (``policies/matching.py``). A goal is *ready* when it is free (not ``filled``),
nothing lies over it and every goal it stands on is ``filled``: a bin's goals all are, a
tower's only the lowest free level.

A policy trained on a tower of 3 levels sees absolute heights 2-10 cm; a tower of 6 has
levels at 14-22 cm that it never saw, and a red level at 14 cm that accepts the red block as
well as the red level at 2 cm did (``examples/tasks/rgb-tower-6.toml``). Whether a goal is
ready does not grow with the tower: it is the column ``goal:ready``
(:class:`~manigraph_planner.gnn.task_features.TaskFeatures`, ``goal_support``), computed from
the Scene alone, so from the task file's ``filled`` and never from a rules file.
"""

from __future__ import annotations

from manigraph_planner.scene_geometry import SceneGeometry
from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneGoal

__all__ = ["READY_COLUMN", "ready_goals", "stands_on_goals", "supports_of"]

#: The column a ready goal reads 1 in (0 on objects and on other goals).
READY_COLUMN = "goal:ready"
#: Slack (metres) in telling which goals a goal stands on (the expert's).
SUPPORT_MARGIN = 0.002
_CATEGORY = {ObjectCategory.BLOCK: GoalCategory.BLOCK, ObjectCategory.COVER: GoalCategory.COVER}


def supports_of(scene: Scene) -> dict[str, list[str]]:
    """Per visible goal, the ids of the visible goals it stands on (none: on the table)."""
    goals = [g for g in scene.goals if g.visible]
    found: dict[str, list[str]] = {}
    for goal in goals:
        sizes = [o.size for o in scene.objects if _CATEGORY.get(o.category) is goal.category]
        if not sizes:
            found[goal.id] = []
            continue
        reach_x = max(s.x for s in sizes) - SUPPORT_MARGIN
        reach_y = max(s.y for s in sizes) - SUPPORT_MARGIN
        tallest = max(s.z for s in sizes) + SUPPORT_MARGIN
        shortest = min(s.z for s in sizes) - SUPPORT_MARGIN
        found[goal.id] = [
            other.id
            for other in goals
            if other.category is goal.category
            and shortest <= goal.position.z - other.position.z <= tallest
            and abs(goal.position.x - other.position.x) < reach_x
            and abs(goal.position.y - other.position.y) < reach_y
        ]
    return found


def stands_on_goals(scene: Scene) -> bool:
    """Some goal of ``scene`` stands on another (a tower, a pyramid)."""
    return any(supports_of(scene).values())


def ready_goals(scene: Scene) -> frozenset[str]:
    """Ids of the goals that can be filled now (module docstring)."""
    supports = supports_of(scene)
    filled = {g.id for g in scene.goals if g.filled}
    geometry = SceneGeometry(scene)
    by_id: dict[str, SceneGoal] = {g.id: g for g in scene.goals}
    return frozenset(
        goal_id
        for goal_id, under in supports.items()
        if goal_id not in filled
        and not geometry.is_blocked(by_id[goal_id])
        and all(s in filled for s in under)
    )
