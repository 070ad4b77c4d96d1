"""A task layout as the contract's ``TaskLayout`` message (what perception needs to know of
an episode: its objects, its goals and its boxes)."""

from __future__ import annotations

from manigraph_shared.messages import (
    GoalCategory,
    LayoutContainer,
    LayoutGoal,
    LayoutObject,
    ObjectCategory,
    TaskLayout,
    Vector3,
)
from manigraph_sim.tasks.base import Layout
from manigraph_sim.world_model import vector


def layout_message(layout: Layout, episode_id: str, stamp: float) -> TaskLayout:
    return TaskLayout(
        episode_id=episode_id,
        stamp=stamp,
        objects=[
            LayoutObject(
                id=body.id,
                category=ObjectCategory(body.category),
                size=vector(body.size),
                position=vector(body.position),
                attributes=dict(body.attributes),
            )
            for body in layout.bodies
        ],
        goals=[
            LayoutGoal(
                id=goal.id,
                category=GoalCategory(goal.category),
                position=vector(goal.position),
                optional=goal.id in layout.optional_goals,
                accepts=dict(goal.accepts),
                attributes=dict(goal.attributes),
            )
            for goal in layout.goals
        ],
        containers=[
            LayoutContainer(
                id=box.id,
                centre=Vector3(x=float(box.centre[0]), y=float(box.centre[1]), z=0.0),
                inner=Vector3(x=float(box.inner[0]), y=float(box.inner[1]), z=box.height),
            )
            for box in layout.containers
        ],
        partially_observable=layout.partially_observable,
    )
