"""The size-sort task (docs/tasks/size-sort.md): seeded layouts that fit, and a success check
that only the right size passes, on the real geometric world."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest, GripperOp, RobotCommand, Scene
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.tasks import TASKS, get_task
from manigraph_sim.tasks.base import TaskParams
from manigraph_sim.tasks.size_sort import LARGE, SMALL
from manigraph_sim.world_model import Layout


def layout(blocks: int, seed: int) -> Layout:
    return get_task("size-sort", TaskParams(blocks=blocks)).layout(np.random.default_rng(seed))


def command(op: GripperOp, object_id: str, position: object) -> RobotCommand:
    return RobotCommand(
        command_id="c", decision_id="d", op=op, object_id=object_id, position=position, stamp=0.0
    )


def move(sim: GeometricBackend, scene: Scene, object_id: str, goal_id: str) -> Scene:
    return put(sim, scene, object_id, scene.goal(goal_id).position)


def put(sim: GeometricBackend, scene: Scene, object_id: str, position: object) -> Scene:
    item = scene.object(object_id)
    assert sim.execute(command(GripperOp.PICK, item.id, item.position), 0.0).ok
    assert sim.execute(command(GripperOp.PLACE, item.id, position), 0.0).ok
    after = sim.scene(0.0)
    assert after is not None
    return after


def test_size_sort_is_a_registered_task() -> None:
    assert "size-sort" in TASKS


@pytest.mark.parametrize(("blocks", "stacks"), [(1, 1), (9, 1), (4, 2)])
def test_parameters_that_do_not_fit_are_refused_by_name(blocks: int, stacks: int) -> None:
    with pytest.raises(TaskError, match=r"^(blocks|stacks): "):
        get_task("size-sort", TaskParams(blocks=blocks, stacks=stacks))


@pytest.mark.parametrize("blocks", range(2, 9))
def test_each_bin_has_one_goal_per_block_of_its_size_and_nothing_overlaps(blocks: int) -> None:
    for seed in range(30):
        scene = layout(blocks, seed)
        scene.validate()
        sides = [float(b.size[2]) for b in scene.bodies]
        assert set(sides) == {SMALL, LARGE}  # both sizes, always
        small_bin, large_bin = scene.containers
        small_goals = [g for g in scene.goals if g.id.startswith("small")]
        large_goals = [g for g in scene.goals if g.id.startswith("large")]
        assert len(small_goals) == sides.count(SMALL) and len(large_goals) == sides.count(LARGE)
        for goals, box, side in ((small_goals, small_bin, SMALL), (large_goals, large_bin, LARGE)):
            for goal in goals:
                assert goal.position[2] == pytest.approx(side / 2)
                assert box.fits_inside(goal.position, np.full(3, side))
        for body in scene.bodies:  # loose on the table, clear of both bins
            assert body.bottom == pytest.approx(0.0)
            assert not any(box.touches(body.position, body.size) for box in scene.containers)
        for i, a in enumerate(scene.bodies):
            for b in scene.bodies[i + 1 :]:
                gap = np.abs(a.position[:2] - b.position[:2]) - (a.size[:2] + b.size[:2]) / 2
                assert gap.max() > 0, (blocks, seed, a.id, b.id)
        outer = [box.inner + 2 * box.wall for box in scene.containers]
        apart = np.abs(small_bin.centre - large_bin.centre) - (outer[0] + outer[1]) / 2
        assert apart.max() > 0


def test_layouts_are_seeded_and_the_seed_matters() -> None:
    def where(scene: Layout) -> list[list[float]]:
        return [b.position.tolist() for b in scene.bodies] + [
            g.position.tolist() for g in scene.goals
        ]

    assert where(layout(6, 3)) == where(layout(6, 3))
    assert where(layout(6, 3)) != where(layout(6, 4))


def test_a_goal_is_filled_only_by_a_block_of_its_size() -> None:
    sim = GeometricBackend()
    start = sim.reset(EpisodeRequest(episode_id="e", task="size-sort", blocks=4, seed=1), 0.0)
    assert start.goals_total == 4
    scene = sim.scene(0.0)
    assert scene is not None
    small = [o.id for o in scene.objects if o.size.z == pytest.approx(SMALL)]
    large = [o.id for o in scene.objects if o.size.z == pytest.approx(LARGE)]
    small_goals = [g.id for g in scene.goals if g.id.startswith("small")]
    large_goals = [g.id for g in scene.goals if g.id.startswith("large")]
    # Wrong size: it lands in the bin, 2 cm off the goal's centre height, and fills nothing
    # (then back to where it lay).
    for block, goal in ((large[0], small_goals[0]), (small[0], large_goals[0])):
        was = scene.object(block).position
        scene = move(sim, scene, block, goal)
        assert not scene.goal(goal).filled and not scene.object(block).filled
        scene = put(sim, scene, block, was)
    # Right size: filled; every block in the bin of its size ends the episode in success.
    for block, goal in zip(small + large, small_goals + large_goals, strict=True):
        scene = move(sim, scene, block, goal)
        assert scene.goal(goal).filled and scene.object(block).filled
    end = sim.end_event(0.0)
    assert end is not None and end.success and end.goals_filled == 4
