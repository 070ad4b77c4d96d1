"""What a shelf world looks like: a ``Scene`` of blocks and slots. Each slot says its row
(``shelf_row``: ``back`` or ``front``), which is also how the planner knows a shelf scene
(:func:`is_shelf_scene`)."""

from __future__ import annotations

from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneGoal, SceneObject
from manigraph_shelf.shelf_geometry import ROW_ATTRIBUTE, is_shelf_scene
from manigraph_shelf.sim.layout import ShelfLayout
from manigraph_shelf.sim.shelf_world import ShelfWorld
from manigraph_sim.world_model import vector

__all__ = ["ROW_ATTRIBUTE", "is_shelf_scene", "shelf_scene"]


def shelf_scene(
    world: ShelfWorld,
    layout: ShelfLayout,
    episode_id: str,
    stamp: float,
    sequence: int,
    ended: bool,
) -> Scene:
    """``world`` now: every block (filled: in a slot) and every slot (filled: holding one)."""
    in_slot = set(world.occupant.values())
    objects = [
        SceneObject(
            id=body.id,
            category=ObjectCategory.BLOCK,
            position=vector(world.positions[body.id]),
            size=vector(body.size),
            filled=body.id in in_slot,
        )
        for body in layout.bodies
    ]
    goals = [
        SceneGoal(
            id=goal.id,
            category=GoalCategory.BLOCK,
            position=vector(goal.position),
            filled=goal.id in world.occupant,
            attributes=dict(goal.attributes),
        )
        for goal in layout.goals
    ]
    return Scene(
        episode_id=episode_id,
        stamp=stamp,
        sequence=sequence,
        objects=objects,
        goals=goals,
        episode_ended=ended,
    )
