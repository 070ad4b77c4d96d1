"""What a shelf world looks like: a ``Scene`` of blocks, slots and the cupboard. Each slot
says its row (``shelf_row``: ``back`` or ``front``), which is also how the planner knows a
shelf scene (:func:`is_shelf_scene`). The cupboard's panels are fixtures of kinds
``board`` and ``wall`` (:func:`cupboard_fixtures`), so generic viewers and exports show it;
no action operates them and the planner's graph leaves them out."""

from __future__ import annotations

from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneFixture,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shelf.cupboard import cupboard_panels
from manigraph_shelf.shelf_geometry import ROW_ATTRIBUTE, ShelfGeometry, is_shelf_scene
from manigraph_shelf.sim.layout import ShelfLayout
from manigraph_shelf.sim.shelf_world import ShelfWorld
from manigraph_sim.world_model import vector

__all__ = ["ROW_ATTRIBUTE", "cupboard_fixtures", "is_shelf_scene", "shelf_scene"]


def cupboard_fixtures(geometry: ShelfGeometry) -> list[SceneFixture]:
    """Each panel of ``geometry``'s cupboard (:func:`cupboard_panels`, the boxes physics
    builds) as a fixture: its name, kind, centre and full size; no state."""
    return [
        SceneFixture(
            id=panel.name,
            kind=panel.kind,
            position=Vector3(x=panel.centre[0], y=panel.centre[1], z=panel.centre[2]),
            size=Vector3(x=panel.size[0], y=panel.size[1], z=panel.size[2]),
        )
        for panel in cupboard_panels(geometry)
    ]


def shelf_scene(
    world: ShelfWorld,
    layout: ShelfLayout,
    episode_id: str,
    stamp: float,
    sequence: int,
    ended: bool,
) -> Scene:
    """``world`` now: every block (filled: in a slot), every slot (filled: holding one) and
    the cupboard's panels."""
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
        fixtures=cupboard_fixtures(layout.geometry),
        episode_ended=ended,
    )
