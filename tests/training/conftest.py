"""Scenes the training tests build graphs from (real message classes, no fakes)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

BLOCK = 0.04


def _at(x: float, y: float, level: int) -> Vector3:
    return Vector3(x=x, y=y, z=(level + 0.5) * BLOCK)


def stack_scene(k: int) -> Scene:
    """K blocks in one tower, K block goals in another (the paper's K-block stacking)."""
    size = Vector3(x=BLOCK, y=BLOCK, z=BLOCK)
    objects = [
        SceneObject(id=f"b{i}", category="block", position=_at(0.5, -0.2, i), size=size)
        for i in range(k)
    ]
    goals = [SceneGoal(id=f"g{i}", category="block", position=_at(0.5, 0.2, i)) for i in range(k)]
    return Scene(episode_id="test", stamp=1.0, sequence=0, objects=objects, goals=goals)


@pytest.fixture
def make_stack_scene() -> Callable[[int], Scene]:
    return stack_scene
