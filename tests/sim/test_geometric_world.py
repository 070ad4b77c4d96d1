from __future__ import annotations

import numpy as np
import pytest

from manigraph_blocks.sim.geometric_world import GeometricWorld
from manigraph_blocks.sim.options import BlockOptions
from manigraph_shared.errors import ConfigError, SkillError, TaskError
from manigraph_sim.tasks import get_task
from manigraph_sim.world_model import BLOCK_SIZE, Body, Goal

SIZE = np.full(3, BLOCK_SIZE)


def block(name: str, x: float, y: float, level: int) -> Body:
    return Body(name, "block", SIZE.copy(), np.array([x, y, (level + 0.5) * BLOCK_SIZE]))


def goal(name: str, x: float, y: float, level: int) -> Goal:
    return Goal(name, "block", np.array([x, y, (level + 0.5) * BLOCK_SIZE]))


def two_stack_world() -> GeometricWorld:
    bodies = [block("a", 0.5, 0.0, 0), block("b", 0.5, 0.0, 1)]
    goals = [goal("g0", 0.4, 0.2, 0), goal("g1", 0.4, 0.2, 1)]
    return GeometricWorld(bodies, goals)


def test_picking_a_covered_block_fails_and_names_what_covers_it() -> None:
    world = two_stack_world()
    with pytest.raises(SkillError) as caught:
        world.pick("a")
    assert caught.value.reason == "object_covered"
    assert "b" in caught.value.detail
    assert world.held is None


def test_placing_in_the_air_falls_onto_what_is_below() -> None:
    world = two_stack_world()
    world.pick("b")
    rest = world.place("b", np.array([0.4, 0.2, 1.5 * BLOCK_SIZE]))  # g1, but g0 is empty
    assert rest[2] == pytest.approx(0.5 * BLOCK_SIZE)
    assert world.occupancy() == {"g0": "b"}  # it landed in the lower goal, not g1


def test_inverting_the_stack_fills_every_goal() -> None:
    world = two_stack_world()
    for name, target in (("b", "g0"), ("a", "g1")):
        world.pick(name)
        world.place(name, world.goals[target].position)
    assert world.occupancy() == {"g0": "b", "g1": "a"}
    assert world.goals_filled() == 2


def test_a_block_dropped_beside_a_stack_rests_on_the_table() -> None:
    world = two_stack_world()
    world.pick("b")
    rest = world.place("b", np.array([0.6, 0.0, 0.3]))
    assert rest[2] == pytest.approx(0.5 * BLOCK_SIZE)


def pyramid_missing_one() -> GeometricWorld:
    """A 6-pyramid with its bottom row and the middle row's left block in place, and a
    spare block on the table."""
    from manigraph_blocks.sim.pyramid import pyramid_goals

    goals = pyramid_goals(np.array([0.5, 0.0, 0.0]), 6)
    present = [goals[i] for i in (0, 1, 2, 3)]  # bottom row and the middle row's left block
    bodies = [Body(f"b{i}", "block", SIZE.copy(), g.position.copy()) for i, g in enumerate(present)]
    bodies.append(block("spare", 0.35, -0.2, 0))
    return GeometricWorld(bodies, goals)


def test_a_block_set_on_a_pyramid_top_over_one_block_tips_off_into_the_gap() -> None:
    world = pyramid_missing_one()
    top, missing = world.goals["goal_5"], world.goals["goal_4"]
    world.pick("spare")
    rest = world.place("spare", top.position)
    # its centre was 2 mm past the edge of the one block under it: it tips off that edge and
    # lands one level lower, beside it, which is the missing middle block's goal
    assert rest[2] == pytest.approx(missing.position[2])
    assert world.occupancy().get("goal_5") is None
    assert world.occupancy()["goal_4"] == "spare"


def test_a_block_centred_over_two_blocks_or_a_stack_stays() -> None:
    world = pyramid_missing_one()
    world.pick("b3")  # the middle row's left block, onto the right one's goal: two under it
    world.place("b3", world.goals["goal_4"].position)
    assert world.occupancy()["goal_4"] == "b3"
    world = two_stack_world()
    world.pick("b")
    rest = world.place("b", np.array([0.5 + 0.019, 0.0, 0.2]))  # 1 mm inside a's edge
    assert rest == pytest.approx([0.519, 0.0, 1.5 * BLOCK_SIZE])


def test_a_block_overhanging_a_single_block_slides_off_to_the_table() -> None:
    world = two_stack_world()
    world.pick("b")
    rest = world.place("b", np.array([0.5 + 0.025, 0.0, 0.2]))  # centre 5 mm past the edge
    assert rest[2] == pytest.approx(0.5 * BLOCK_SIZE)
    assert rest[0] == pytest.approx(0.5 + BLOCK_SIZE + 0.002)  # just beyond a's edge
    assert world.support_extent(rest, SIZE, ignore="b") is None


def test_a_block_at_a_top_goal_on_a_stray_block_does_not_fill_it() -> None:
    """A 3-pyramid with a block dropped on the table between its two bottom goals (in
    neither): a block set on the top goal stands there, centred on that stray block, but the
    goals under it are free, so the top goal is not filled (and the pyramid cannot be
    finished until both blocks are moved)."""
    from manigraph_blocks.sim.pyramid import pyramid_goals

    goals = pyramid_goals(np.array([0.5, 0.0, 0.0]), 3)
    top = goals[2]
    world = GeometricWorld([block("stray", 0.5, 0.0, 0), block("spare", 0.35, -0.2, 0)], goals)
    world.pick("spare")
    rest = world.place("spare", top.position)
    assert rest == pytest.approx(top.position)  # it stands in the top goal ...
    assert world.occupancy() == {}  # ... which is not filled while the goals under it are free
    assert world.goals_filled() == 0
    assert world.goal_supports()[top.id] == ["goal_0", "goal_1"]


def test_a_stack_goal_over_a_free_goal_is_not_filled() -> None:
    """A block 12 mm off the lowest goal (outside the tolerance) holds one centred on the goal
    above it: that goal is filled only once the one under it is."""
    world = GeometricWorld(
        [block("low", 0.4 + 0.012, 0.2, 0), block("high", 0.4, 0.2, 1)],
        [goal("g0", 0.4, 0.2, 0), goal("g1", 0.4, 0.2, 1)],
    )
    assert world.occupancy() == {}
    world.bodies["low"].position[0] = 0.4 + 0.009
    assert world.occupancy() == {"g0": "low", "g1": "high"}
    assert world.goal_supports() == {"g0": [], "g1": ["g0"]}


@pytest.mark.parametrize(
    ("task", "params", "supported"),
    [
        ("stack", BlockOptions(blocks=5), [1, 1, 1, 1]),
        ("multistack", BlockOptions(blocks=3, stacks=3), [1, 1] * 3),
        ("pyramid", BlockOptions(blocks=6), [2, 2, 2]),
        ("pyramid", BlockOptions(blocks=10), [2] * 6),
        ("box-rearrangement", BlockOptions(blocks=4), []),
        ("box-pack", BlockOptions(blocks=3), []),
    ],
)
def test_goal_supports_of_the_tasks(task: str, params: BlockOptions, supported: list[int]) -> None:
    """Every goal off the table stands on the goals under it (one in a stack, two in a
    pyramid); the box tasks' goals stand on a box floor, a rim or the table."""
    layout = get_task(task, params).layout(np.random.default_rng(3))
    world = GeometricWorld(layout.bodies, layout.goals, containers=layout.containers)
    counts = [len(under) for under in world.goal_supports().values() if under]
    assert counts == supported


def test_gripper_holds_one_object_at_a_time() -> None:
    world = GeometricWorld([block("a", 0.5, 0, 0), block("c", 0.6, 0, 0)], [])
    world.pick("a")
    with pytest.raises(SkillError, match="gripper_full"):
        world.pick("c")
    with pytest.raises(SkillError, match="not_holding"):
        world.place("c", np.zeros(3))


def test_goal_tolerance_decides_filled() -> None:
    world = GeometricWorld([block("a", 0.5, 0.0, 0)], [goal("g", 0.5 + 0.009, 0.0, 0)])
    assert world.goals_filled() == 1
    world.goals["g"].position[0] = 0.5 + 0.011
    assert world.goals_filled() == 0


def test_stack_layout_is_seeded() -> None:
    task = get_task("stack", BlockOptions(blocks=5))
    first = task.layout(np.random.default_rng(7))
    again = task.layout(np.random.default_rng(7))
    other = task.layout(np.random.default_rng(8))
    assert [b.position.tolist() for b in first.bodies] == [
        b.position.tolist() for b in again.bodies
    ]
    assert first.bodies[0].position.tolist() != other.bodies[0].position.tolist()
    assert len(first.bodies) == len(first.goals) == 5
    # The goal stack stands apart from the start stack.
    assert (
        np.linalg.norm(first.bodies[0].position[:2] - first.goals[0].position[:2]) >= 3 * BLOCK_SIZE
    )


def test_unknown_task_and_bad_parameters_are_named() -> None:
    with pytest.raises(ConfigError, match=r"task: 'tower' is not one of: .*, stack, multistack"):
        get_task("tower", BlockOptions())
    with pytest.raises(TaskError, match="stacks"):
        get_task("stack", BlockOptions(stacks=2))
