"""The world model's rules on hand-made observations: filling with hysteresis, staleness."""

from __future__ import annotations

import numpy as np

from manigraph_perception.detection import ObjectPose
from manigraph_perception.world_belief import WorldConfig, WorldModel, quaternion_of
from manigraph_shared.messages import LayoutGoal, LayoutObject, TaskLayout, Vector3

BLOCK = Vector3(x=0.04, y=0.04, z=0.04)


def _layout() -> TaskLayout:
    return TaskLayout(
        episode_id="e1",
        stamp=0.0,
        objects=[
            LayoutObject(id="block_0", category="block", size=BLOCK, position=BLOCK),
        ],
        goals=[LayoutGoal(id="goal_0", category="block", position=Vector3(x=0.5, y=0.0, z=0.02))],
    )


def _seen_at(dx: float) -> list[ObjectPose]:
    pose = np.eye(4)
    pose[:3, 3] = [0.5 + dx, 0.0, 0.02]
    return [ObjectPose("block_0", pose, 1, 0.1)]


def test_filled_has_hysteresis() -> None:
    world = WorldModel(WorldConfig(fill_enter=0.02, fill_exit=0.03))  # as in the sim
    world.set_layout(_layout())
    filled = []
    for t, dx in enumerate([0.025, 0.015, 0.025, 0.029, 0.035, 0.025, 0.01]):
        world.update(_seen_at(dx), float(t))
        scene = world.scene(float(t), float(t))
        assert scene is not None
        filled.append(scene.goal("goal_0").filled)
    assert filled == [False, True, True, True, False, False, True]


def test_a_world_without_frames_goes_stale() -> None:
    world = WorldModel(WorldConfig(stale_after=2.0))
    world.set_layout(_layout())
    world.update(_seen_at(0.0), 10.0)
    assert not world.stale(11.0)
    assert world.stale(12.5)


def test_a_new_episode_forgets_the_old_world() -> None:
    world = WorldModel()
    world.set_layout(_layout())
    world.update(_seen_at(0.0), 1.0)
    assert not world.set_layout(_layout())  # the same episode again: kept
    assert world.filled_by == {"goal_0": "block_0"}
    assert world.set_layout(_layout().replace(episode_id="e2"))
    assert world.filled_by == {} and world.stale(1.0)


def test_quaternion_of_a_rotation() -> None:
    angle = 0.3
    rotation = np.array(
        [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    )
    assert np.allclose(quaternion_of(rotation), [0, 0, np.sin(angle / 2), np.cos(angle / 2)])


def test_a_carried_block_lands_on_its_goal_until_seen_elsewhere() -> None:
    world = WorldModel()
    world.set_layout(_layout())
    start = world.beliefs["block_0"].position.copy()
    world.on_action("other-episode", "block_0", "goal_0")  # not this episode: ignored
    world.on_gripper(0.04)
    world.on_gripper(0.08)
    assert np.array_equal(world.beliefs["block_0"].position, start)
    world.on_action("e1", "block_0", "goal_0")
    world.on_gripper(0.08)  # opening before holding: nothing moved
    assert np.array_equal(world.beliefs["block_0"].position, start)
    world.on_gripper(0.04)  # closed on the block
    world.on_gripper(0.08)  # let go at the goal
    assert np.allclose(world.beliefs["block_0"].position, [0.5, 0.0, 0.02])
    assert world.filled_by == {"goal_0": "block_0"}
    world.update(_seen_at(0.1), 5.0)  # a marker says it is elsewhere: the marker wins
    assert np.isclose(world.beliefs["block_0"].position[0], 0.6)


def test_a_grasp_that_closes_on_nothing_moves_nothing() -> None:
    world = WorldModel()
    world.set_layout(_layout())
    start = world.beliefs["block_0"].position.copy()
    world.on_action("e1", "block_0", "goal_0")
    world.on_gripper(0.0)  # closed on nothing (grasp slipped)
    world.on_gripper(0.08)
    assert np.array_equal(world.beliefs["block_0"].position, start)
    world.on_gripper(0.04)
    world.on_gripper(0.0)  # held, then lost on the way
    world.on_gripper(0.08)
    assert np.array_equal(world.beliefs["block_0"].position, start)


def test_a_block_let_go_of_a_little_wider_than_it_lands_on_its_goal() -> None:
    """The skills let a block go with the fingers 6 cm apart (2 cm wider than it: fully open,
    a finger jammed against a bin's wall), a width that was "holding" before: the opening
    beyond the grip says it was let go of. Fingers left 6 cm open are no grip."""
    world = WorldModel()
    world.set_layout(_layout())
    start = world.beliefs["block_0"].position.copy()
    world.on_gripper(0.06)  # the last release left them so
    world.on_action("e1", "block_0", "goal_0")
    world.on_gripper(0.06)  # not closed on anything yet
    world.on_gripper(0.08)  # opened for the grasp
    assert np.array_equal(world.beliefs["block_0"].position, start)
    world.on_gripper(0.0395)  # closed on the block
    world.on_gripper(0.0405)  # carried: a grip loosens by a millimetre
    assert np.array_equal(world.beliefs["block_0"].position, start)
    world.on_gripper(0.06)  # let go, 2 cm wider
    assert np.allclose(world.beliefs["block_0"].position, [0.5, 0.0, 0.02])
    # The next action's grasp, seen only once closed (a sim that reports the joints at the
    # end of each motion): it closed from the 6 cm the release left.
    world.update(_seen_at(0.1), 5.0)
    world.on_action("e1", "block_0", "goal_0")
    world.on_gripper(0.04)
    world.on_gripper(0.06)
    assert np.allclose(world.beliefs["block_0"].position, [0.5, 0.0, 0.02])


CAMERA = np.array([0.92, 0.0, 0.45])


def _seen_along_ray(point: list[float], metres: float) -> list[ObjectPose]:
    """block_0 measured ``metres`` off ``point`` along the camera's viewing ray."""
    ray = (np.array(point) - CAMERA) / np.linalg.norm(np.array(point) - CAMERA)
    pose = np.eye(4)
    pose[:3, 3] = np.array(point) + metres * ray
    return [ObjectPose("block_0", pose, 1, 0.1)]


def test_with_a_camera_a_block_off_along_the_ray_rests_on_the_table_on_its_goal() -> None:
    world = WorldModel(camera=CAMERA)
    world.set_layout(_layout())
    world.update(_seen_along_ray([0.5, 0.0, 0.02], 0.03), 1.0)  # 3 cm: past fill_exit
    assert np.linalg.norm(world.beliefs["block_0"].position - [0.5, 0.0, 0.02]) < 1e-6
    assert world.filled_by == {"goal_0": "block_0"}


def test_a_block_seen_on_the_ray_through_its_belief_has_not_moved() -> None:
    world = WorldModel(camera=CAMERA)
    world.set_layout(_layout())
    world.update(_seen_along_ray([0.5, 0.0, 0.02], 0.0), 1.0)
    # Next frame: 4 cm along the same ray (near the table plane of a spot in front of it).
    world.update(_seen_along_ray([0.5, 0.0, 0.02], -0.04), 2.0)
    assert np.linalg.norm(world.beliefs["block_0"].position - [0.5, 0.0, 0.02]) < 1e-6
    # Seen elsewhere across the image: it moved.
    world.update(_seen_along_ray([0.45, 0.1, 0.02], 0.0), 3.0)
    assert np.linalg.norm(world.beliefs["block_0"].position - [0.45, 0.1, 0.02]) < 1e-6
    assert world.filled_by == {}


def _colour_layout() -> TaskLayout:
    return TaskLayout(
        episode_id="colours",
        stamp=0.0,
        objects=[
            LayoutObject(id="block_0", category="block", size=BLOCK, position=BLOCK),
        ],
        goals=[
            LayoutGoal(
                id="red_slot",
                category="block",
                position=Vector3(x=0.5, y=0.0, z=0.02),
                accepts={"colour": "red"},
            )
        ],
    )


def test_a_goal_fills_only_with_an_object_it_accepts_by_the_markers_attributes() -> None:
    for colour, filled in (("red", True), ("blue", False)):
        world = WorldModel(WorldConfig(fill_enter=0.02, fill_exit=0.03))
        world.set_layout(_colour_layout(), {"block_0": {"colour": colour}})
        world.update(_seen_at(0.0), 1.0)
        scene = world.scene(1.0, 1.0)
        assert scene is not None
        assert scene.object("block_0").attributes == {"colour": colour}
        assert scene.goal("red_slot").accepts == {"colour": "red"}
        assert scene.goal("red_slot").filled is filled
        assert scene.object("block_0").filled is filled
