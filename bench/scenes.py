"""Scenes the benchmarks share (run the benchmarks from the repository root)."""

from __future__ import annotations

from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

BLOCK = 0.04


def stack_scene(k: int) -> Scene:
    """K-block stacking at its start: K blocks in one tower, K free block goals in another."""
    size = Vector3(x=BLOCK, y=BLOCK, z=BLOCK)
    objects = [
        SceneObject(
            id=f"block-{i}",
            category="block",
            size=size,
            position=Vector3(x=0.5, y=-0.2, z=(i + 0.5) * BLOCK),
        )
        for i in range(k)
    ]
    goals = [
        SceneGoal(
            id=f"goal-{i}", category="block", position=Vector3(x=0.5, y=0.2, z=(i + 0.5) * BLOCK)
        )
        for i in range(k)
    ]
    return Scene(episode_id="bench", stamp=1.0, sequence=0, objects=objects, goals=goals)
