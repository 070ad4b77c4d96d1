"""Geometric relations read off a Scene: what rests on what, what is under a cover."""

from __future__ import annotations

from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

MARGIN = 0.002


def _overlaps(position: Vector3, half_x: float, half_y: float, other: SceneObject) -> bool:
    return (
        abs(other.position.x - position.x) < half_x + other.size.x / 2 - MARGIN
        and abs(other.position.y - position.y) < half_y + other.size.y / 2 - MARGIN
    )


def is_covered(scene: Scene, item: SceneObject) -> bool:
    """Another object rests on top of ``item`` (overlapping footprint, above its top)."""
    top = item.position.z + item.size.z / 2
    return any(
        other.id != item.id
        and other.position.z - other.size.z / 2 >= top - MARGIN
        and _overlaps(item.position, item.size.x / 2, item.size.y / 2, other)
        for other in scene.objects
    )


def objects_above_goal(scene: Scene, goal: SceneGoal) -> list[SceneObject]:
    """Objects higher than ``goal`` over its position, i.e. in the way of filling it."""
    return [
        other
        for other in scene.objects
        if other.visible
        and other.position.z - other.size.z / 2 > goal.position.z
        and _overlaps(goal.position, 0.0, 0.0, other)
    ]


def objects_over(scene: Scene, item: SceneObject) -> list[SceneObject]:
    """Objects resting over ``item`` (what must be lifted before it can be picked)."""
    top = item.position.z + item.size.z / 2
    return [
        other
        for other in scene.objects
        if other.id != item.id
        and other.visible
        and other.position.z - other.size.z / 2 >= top - MARGIN
        and _overlaps(item.position, item.size.x / 2, item.size.y / 2, other)
    ]
