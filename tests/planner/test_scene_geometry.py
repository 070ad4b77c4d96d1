"""The vectorised scene relations agree with their per-pair definitions on every pair."""

from __future__ import annotations

import random

import pytest

from manigraph_planner.scene_geometry import MARGIN, SceneGeometry
from manigraph_shared.messages import (
    EpisodeRequest,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_sim.geometric.backend import GeometricBackend


# --- the per-pair definitions (what the expert used before it was vectorised) ----------------
def _overlaps(position: Vector3, half_x: float, half_y: float, other: SceneObject) -> bool:
    return (
        abs(other.position.x - position.x) < half_x + other.size.x / 2 - MARGIN
        and abs(other.position.y - position.y) < half_y + other.size.y / 2 - MARGIN
    )


def is_covered(scene: Scene, item: SceneObject) -> bool:
    top = item.position.z + item.size.z / 2
    return any(
        other.id != item.id
        and other.position.z - other.size.z / 2 >= top - MARGIN
        and _overlaps(item.position, item.size.x / 2, item.size.y / 2, other)
        for other in scene.objects
    )


def objects_above_goal(scene: Scene, goal: SceneGoal) -> list[SceneObject]:
    return [
        other
        for other in scene.objects
        if other.visible
        and other.position.z - other.size.z / 2 > goal.position.z
        and _overlaps(goal.position, 0.0, 0.0, other)
    ]


def objects_over(scene: Scene, item: SceneObject) -> list[SceneObject]:
    top = item.position.z + item.size.z / 2
    return [
        other
        for other in scene.objects
        if other.id != item.id
        and other.visible
        and other.position.z - other.size.z / 2 >= top - MARGIN
        and _overlaps(item.position, item.size.x / 2, item.size.y / 2, other)
    ]


def random_scene(rng: random.Random, count: int) -> Scene:
    """Blocks of two sizes on a coarse grid, so that footprints touch, overlap by exactly the
    margin, or stack, as often as they miss each other."""
    objects, goals = [], []
    for i in range(count):
        size = rng.choice([0.04, 0.05])
        objects.append(
            SceneObject(
                id=f"o{i}",
                category=rng.choice(["block", "cover"]),
                position=Vector3(
                    x=rng.randrange(6) * 0.02,
                    y=rng.randrange(3) * 0.02,
                    z=rng.randrange(4) * 0.04 + rng.choice([0.0, 0.002, 0.02]),
                ),
                size=Vector3(x=size, y=size, z=rng.choice([0.04, 0.02])),
                visible=rng.random() > 0.2,
            )
        )
        goals.append(
            SceneGoal(
                id=f"g{i}",
                category="block",
                position=Vector3(
                    x=rng.randrange(6) * 0.02, y=rng.randrange(3) * 0.02, z=rng.randrange(4) * 0.04
                ),
            )
        )
    return Scene(episode_id="e", stamp=1.0, sequence=0, objects=objects, goals=goals)


def task_scene(task: str, blocks: int, seed: int) -> Scene:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="e", task=task, blocks=blocks, seed=seed), 0.0)
    scene = sim.scene(1.0)
    assert scene is not None
    return scene


def assert_agree(scene: Scene) -> int:
    """Every relation of ``scene`` both ways; returns how many held (so a test can insist
    that its scenes exercise them)."""
    geometry = SceneGeometry(scene)
    held = 0
    for item in scene.objects:
        assert geometry.is_covered(item) == is_covered(scene, item), item.id
        assert geometry.objects_over(item) == objects_over(scene, item), item.id
        held += is_covered(scene, item)
    for goal in scene.goals:
        assert geometry.objects_above_goal(goal) == objects_above_goal(scene, goal), goal.id
        assert geometry.is_blocked(goal) == bool(objects_above_goal(scene, goal)), goal.id
        held += bool(objects_above_goal(scene, goal))
    return held


def test_random_crowded_scenes_agree_pair_by_pair() -> None:
    rng = random.Random(7)
    held = sum(assert_agree(random_scene(rng, rng.randrange(1, 30))) for _ in range(200))
    assert held > 500  # the scenes are crowded enough to say something


@pytest.mark.parametrize(
    ("task", "blocks"), [("stack", 40), ("pyramid", 6), ("box-rearrangement", 4)]
)
def test_task_scenes_agree(task: str, blocks: int) -> None:
    for seed in range(3):
        assert assert_agree(task_scene(task, blocks, seed)) > 0


def test_goals_of_a_scene_without_objects_have_nothing_above_them() -> None:
    goal = SceneGoal(id="g", category="block", position=Vector3(x=0.0, y=0.0, z=0.02))
    scene = Scene(episode_id="e", stamp=1.0, sequence=0, objects=[], goals=[goal])
    assert SceneGeometry(scene).objects_above_goal(goal) == []
