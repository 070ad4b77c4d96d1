"""The hand-designed expert of the paper: highest movable block to the lowest free goal."""

from __future__ import annotations

from manigraph_planner.policies.base import Decision, Policy, register_policy
from manigraph_planner.scene_geometry import is_covered
from manigraph_shared.messages import Scene


@register_policy("expert")
class ExpertPolicy(Policy):
    """Pick the highest visible, uncovered object not yet in a goal; place it in the lowest
    free goal of its category. Ties go to the smaller id, so decisions are deterministic."""

    def decide(self, scene: Scene) -> Decision | None:
        free_goals = [g for g in scene.goals if g.visible and not g.filled]
        movable = [
            o
            for o in scene.objects
            if o.visible
            and not o.filled
            and not is_covered(scene, o)
            and any(g.category.value == o.category.value for g in free_goals)
        ]
        if not movable:
            return None
        target = max(movable, key=lambda o: (o.position.z, _neg(o.id)))
        goals = [g for g in free_goals if g.category.value == target.category.value]
        goal = min(goals, key=lambda g: (round(g.position.z, 4), g.id))
        return Decision(object_id=target.id, goal_id=goal.id)


def _neg(text: str) -> tuple[int, ...]:
    """Sort key that prefers the smaller id under ``max``."""
    return tuple(-ord(c) for c in text)
