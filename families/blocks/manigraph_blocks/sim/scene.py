"""What a sim backend observes: a ``Scene`` read off a geometric world, the same rules for
every backend (goal occupancy, and what a closed box hides under partial observability).
Objects carry their attributes and goals what they accept; a goal is filled only by an object
it accepts."""

from __future__ import annotations

from collections.abc import Mapping

from manigraph_blocks.sim.geometric_world import GeometricWorld
from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Quaternion,
    Scene,
    SceneGoal,
    SceneObject,
)
from manigraph_sim.world_model import vector


def observed_scene(
    world: GeometricWorld,
    episode_id: str,
    stamp: float,
    sequence: int,
    ended: bool,
    orientations: Mapping[str, Quaternion] | None = None,
) -> Scene:
    """Observe ``world`` now (boxes open now stay revealed) and describe it. Objects without
    an entry in ``orientations`` are axis-aligned."""
    world.observe()
    occupancy = world.occupancy()
    in_goal = set(occupancy.values())
    orientations = orientations or {}
    objects = [
        SceneObject(
            id=body.id,
            category=ObjectCategory(body.category),
            position=vector(body.position),
            orientation=orientations.get(body.id, Quaternion()),
            size=vector(body.size),
            filled=body.id in in_goal,
            visible=not world.is_hidden(body.position),
            attributes=dict(body.attributes),
        )
        for body in world.bodies.values()
    ]
    goals = [
        SceneGoal(
            id=goal.id,
            category=GoalCategory(goal.category),
            position=vector(goal.position),
            filled=goal.id in occupancy,
            visible=not world.is_hidden(goal.position),
            accepts=dict(goal.accepts),
            attributes=dict(goal.attributes),
        )
        for goal in world.goals.values()
    ]
    return Scene(
        episode_id=episode_id,
        stamp=stamp,
        sequence=sequence,
        objects=objects,
        goals=goals,
        episode_ended=ended,
    )
