"""Every registered task: seeded layouts, honest geometry, and solvable by the expert."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_blocks.planner.expert import ExpertPolicy
from manigraph_blocks.sim.options import BlockOptions
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeEvent, EpisodeRequest, GripperOp, RobotCommand
from manigraph_sim.family import family_of
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.tasks import TASKS, get_task


def command(op: GripperOp, object_id: str, position: object) -> RobotCommand:
    return RobotCommand(
        command_id="c", decision_id="d", op=op, object_id=object_id, position=position, stamp=0.0
    )


def run_expert(task: str, blocks: int, stacks: int = 1, seed: int = 0) -> EpisodeEvent | None:
    """Drive the backend with the expert in-process; None if the expert gets stuck."""
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="e", task=task, blocks=blocks, stacks=stacks, seed=seed), 0)
    expert = ExpertPolicy()
    for _ in range(500):
        end = sim.end_event(0.0)
        if end is not None:
            return end
        scene = sim.scene(0.0)
        assert scene is not None
        decision = expert.decide(scene)
        if decision is None:
            return None
        item, goal = scene.object(decision.object_id), scene.goal(decision.goal_id)
        if sim.execute(command(GripperOp.PICK, item.id, item.position), 0.0).ok:
            sim.execute(command(GripperOp.PLACE, item.id, goal.position), 0.0)
    raise AssertionError("episode never ended")


def test_the_suite_has_the_paper_tasks() -> None:
    assert set(TASKS) >= {
        "stack",
        "pyramid",
        "multistack",
        "box-pack",
        "box-unpack",
        "box-rearrangement",
    }


@pytest.mark.parametrize(
    ("task", "blocks", "stacks"),
    [
        ("stack", 9, 1),
        ("pyramid", 6, 1),
        ("multistack", 3, 3),
        ("box-pack", 4, 1),
        ("box-unpack", 3, 1),
    ],
)
def test_expert_solves_every_fully_observed_task(task: str, blocks: int, stacks: int) -> None:
    for seed in range(5):
        end = run_expert(task, blocks, stacks, seed)
        assert end is not None and end.success, (task, seed)
        assert end.goals_filled == end.goals_total


@pytest.mark.parametrize("task", sorted(TASKS))
def test_layouts_are_seeded(task: str) -> None:
    stacks = 2 if task == "multistack" else 1
    request = EpisodeRequest(episode_id="e", task=task, blocks=3, stacks=stacks)
    params = family_of(request).options(request)  # each task with its family's options
    a = get_task(task, params).layout(np.random.default_rng(5))
    b = get_task(task, params).layout(np.random.default_rng(5))
    c = get_task(task, params).layout(np.random.default_rng(6))
    assert [x.position.tolist() for x in a.bodies] == [x.position.tolist() for x in b.bodies]
    assert [x.position.tolist() for x in a.goals] == [x.position.tolist() for x in b.goals]
    assert [x.position.tolist() for x in a.bodies] != [x.position.tolist() for x in c.bodies]


def test_pyramid_upper_goals_rest_on_two_below() -> None:
    layout = get_task("pyramid", BlockOptions(blocks=6)).layout(np.random.default_rng(0))
    levels = sorted({round(g.position[2], 4) for g in layout.goals})
    rows = [sum(1 for g in layout.goals if round(g.position[2], 4) == z) for z in levels]
    assert rows == [3, 2, 1]


def test_box_pack_starts_closed_and_storage_is_optional() -> None:
    sim = GeometricBackend()
    start = sim.reset(EpisodeRequest(episode_id="e", task="box-pack", blocks=3, seed=1), 0.0)
    assert start.goals_total == 4  # three block goals and the lid; not the storage place
    scene = sim.scene(0.0)
    assert scene is not None
    assert scene.goal("lid_goal_0").filled and scene.object("cover_0").filled
    # A block put into the closed box lands on the cover: the goal stays empty.
    top = max((o for o in scene.objects if o.category == "block"), key=lambda o: o.position.z)
    assert sim.execute(command(GripperOp.PICK, top.id, top.position), 0.0).ok
    sim.execute(command(GripperOp.PLACE, top.id, scene.goal("goal_0").position), 0.0)
    after = sim.scene(0.0)
    assert after is not None and not after.goal("goal_0").filled
    assert after.object(top.id).position.z > scene.goal("lid_goal_0").position.z


@pytest.mark.parametrize("task", ["box-pack", "box-unpack", "box-rearrangement"])
def test_every_storage_place_takes_a_cover(task: str) -> None:
    """A storage place never lies so close to a box that a cover put there rests on the
    box's rim (sites 20 cm apart can still be 15 cm apart in x and y; a cover is 16 cm)."""
    for seed in range(200):
        request = EpisodeRequest(episode_id="e", task=task, blocks=4, seed=seed)
        for store in _storage_places(request):
            sim = GeometricBackend()
            sim.reset(request, 0.0)
            scene = sim.scene(0.0)
            assert scene is not None
            cover, goal = scene.object("cover_0"), scene.goal(store)
            assert sim.execute(command(GripperOp.PICK, cover.id, cover.position), 0.0).ok
            assert sim.execute(command(GripperOp.PLACE, cover.id, goal.position), 0.0).ok
            after = sim.scene(0.0)
            assert after is not None and after.goal(store).filled, f"seed {seed}: {store}"


def _storage_places(request: EpisodeRequest) -> list[str]:
    sim = GeometricBackend()
    sim.reset(request, 0.0)
    scene = sim.scene(0.0)
    assert scene is not None
    return [g.id for g in scene.goals if g.id.startswith("storage")]


def test_blocks_in_a_closed_box_cannot_be_picked() -> None:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="e", task="box-unpack", blocks=2, seed=0), 0.0)
    scene = sim.scene(0.0)
    assert scene is not None
    feedback = sim.execute(command(GripperOp.PICK, "block_0", scene.object("block_0").position), 0)
    assert not feedback.ok and feedback.reason == "object_covered"


def test_rearrangement_hides_what_is_in_closed_boxes_until_opened() -> None:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="e", task="box-rearrangement", blocks=3, seed=2), 0.0)
    scene = sim.scene(0.0)
    assert scene is not None
    visible = {e.id for e in [*scene.objects, *scene.goals] if e.visible}
    assert visible == {"cover_0", "cover_1", "lid_goal_0", "lid_goal_1", "storage_0", "storage_1"}
    cover = scene.object("cover_0")
    assert sim.execute(command(GripperOp.PICK, "cover_0", cover.position), 0.0).ok
    sim.execute(command(GripperOp.PLACE, "cover_0", scene.goal("storage_0").position), 0.0)
    opened = sim.scene(0.0)
    assert opened is not None
    assert all(opened.object(f"block_{i}").visible for i in range(3))
    assert not any(g.visible for g in opened.goals if g.id.startswith("goal_"))  # still closed


@pytest.mark.parametrize(
    ("task", "params", "field"),
    [
        ("box-pack", BlockOptions(blocks=10), "blocks"),
        ("multistack", BlockOptions(blocks=3, stacks=9), "stacks"),
        ("pyramid", BlockOptions(blocks=3, stacks=2), "stacks"),
    ],
)
def test_out_of_range_parameters_are_named(task: str, params: BlockOptions, field: str) -> None:
    with pytest.raises(TaskError, match=field):
        get_task(task, params)


def test_what_was_seen_in_an_opened_box_stays_known_after_it_closes() -> None:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="e", task="box-rearrangement", blocks=2, seed=3), 0.0)
    scene = sim.scene(0.0)
    assert scene is not None
    lid, storage = scene.goal("lid_goal_0").position, scene.goal("storage_0").position
    for target in (storage, lid):  # open box 0, then close it again
        cover = sim.scene(0.0).object("cover_0")  # type: ignore[union-attr]
        assert sim.execute(command(GripperOp.PICK, "cover_0", cover.position), 0.0).ok
        assert sim.execute(command(GripperOp.PLACE, "cover_0", target), 0.0).ok
    closed_again = sim.scene(0.0)
    assert closed_again is not None and closed_again.goal("lid_goal_0").filled
    assert closed_again.object("block_0").visible and closed_again.object("block_1").visible
