"""Scene factories shared by the planner tests (real message classes, no fakes)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

BLOCK = 0.04


def block(name: str, x: float, y: float, level: int, **flags: bool) -> SceneObject:
    return SceneObject(
        id=name,
        category="block",
        position=Vector3(x=x, y=y, z=(level + 0.5) * BLOCK),
        size=Vector3(x=BLOCK, y=BLOCK, z=BLOCK),
        **flags,
    )


def block_goal(name: str, x: float, y: float, level: int, **flags: bool) -> SceneGoal:
    return SceneGoal(
        id=name, category="block", position=Vector3(x=x, y=y, z=(level + 0.5) * BLOCK), **flags
    )


def stack_scene(k: int) -> Scene:
    """K blocks in one tower, K block goals in another (the paper's K-block stacking)."""
    objects = [block(f"b{i}", 0.5, -0.2, i) for i in range(k)]
    goals = [block_goal(f"g{i}", 0.5, 0.2, i) for i in range(k)]
    return Scene(episode_id="test", stamp=1.0, sequence=0, objects=objects, goals=goals)


@pytest.fixture
def make_stack_scene() -> Callable[[int], Scene]:
    return stack_scene
