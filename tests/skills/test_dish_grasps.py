"""How the Panda takes a dish between its neighbours: the fingers open little wider than the
dish (``Grasp.opening``: chosen from the dish, checked by the arm-collision model at that
width, sent with every trajectory point so that the sim and the Franka open the hand that
far), and a low dish is taken higher when the hand would come down onto a taller one."""

from __future__ import annotations

import numpy as np
import pytest
from arm_helpers import PerfectArm, block, trajectory_of

from manigraph_shared.messages import (
    GoalCategory,
    GripperTarget,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.orientations import ORIENTATIONS, UPRIGHT
from manigraph_shared.panda import FINGER_OPEN
from manigraph_shared.rotations import rotation_matrix
from manigraph_skills.drivers.base import Motion
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.grasp_choice import (
    GRIP_DEPTH,
    HAND_ABOVE_TCP,
    OPENING_MARGIN,
    choose_grasps,
    dish_opening,
)
from manigraph_skills.motion import HOME_Q, GraspPlanner, PandaModel
from manigraph_skills.motion.collision import ArmCollisionModel
from manigraph_skills.obstacles import Obstacle

PLATE = Vector3(x=0.064, y=0.064, z=0.015)
BOWL = Vector3(x=0.05, y=0.05, z=0.035)


def dish(name: str, kind: ObjectCategory, orientation: int, x: float, y: float) -> SceneObject:
    size = PLATE if kind is ObjectCategory.PLATE else BOWL
    up = [size.z, size.z, size.y, size.y, size.x, size.x][orientation]
    return SceneObject(
        id=name,
        category=kind,
        position=Vector3(x=x, y=y, z=up / 2),
        orientation=ORIENTATIONS[orientation],
        size=size,
    )


def scene(*objects: SceneObject) -> Scene:
    goal = SceneGoal(
        id="goal_0", category=GoalCategory.PLATE, position=Vector3(x=0.5, y=0.3, z=0.05)
    )
    return Scene(episode_id="e", stamp=1.0, sequence=0, objects=list(objects), goals=[goal])


def test_a_dish_is_taken_with_the_fingers_open_to_its_width_a_block_fully() -> None:
    on_rim = dish("plate_0", ObjectCategory.PLATE, UPRIGHT, 0.4, 0.0)
    flat = dish("plate_1", ObjectCategory.PLATE, 0, 0.4, 0.2)
    bowl = dish("bowl_0", ObjectCategory.BOWL, 1, 0.4, -0.2)
    s = scene(on_rim, flat, bowl, block("block_0", 0.3, 0.3))
    goal = s.goals[0].position
    pick, place = choose_grasps(s, on_rim, goal)
    # Across its 1.5 cm thickness, and let go of in its slot as wide.
    assert pick.opening == place.opening == pytest.approx(PLATE.z + OPENING_MARGIN)
    # A bowl's 7 cm would spare the neighbours half a centimetre a side: fully open.
    assert choose_grasps(s, bowl, goal)[0].opening == pytest.approx(2 * FINGER_OPEN)
    # A plate lying flat is as wide as the fingers open: fully.
    assert choose_grasps(s, flat, goal)[0].opening == pytest.approx(2 * FINGER_OPEN)
    assert choose_grasps(s, s.object("block_0"), goal)[0].opening is None
    # Along a given closing axis: the dish's extent along it.
    across = np.array([0.0, 0.0, 1.0])  # the plate's thickness, as it lies on its rim
    assert dish_opening(on_rim, on_rim_thin(on_rim)) == pytest.approx(PLATE.z + OPENING_MARGIN)
    assert dish_opening(flat, across) == pytest.approx(PLATE.z + OPENING_MARGIN)


def on_rim_thin(plate: SceneObject) -> np.ndarray:
    """The world direction of a plate's thin axis."""
    return rotation_matrix(plate.orientation)[:, 2]


def test_a_neighbour_beside_fully_open_fingers_is_clear_of_fingers_opened_to_the_dish() -> None:
    collision = ArmCollisionModel(PandaModel())
    planner = GraspPlanner(PandaModel())
    # Fingers closing along x (hand yaw pi/2) around a point at x = 0.4 m; a thin wall
    # 5.5 cm beyond it along x: within the fully open fingers' reach (6.6 cm), not within
    # fingers 3.5 cm apart (their outer faces ~4.5 cm out).
    pick = planner.pick(HOME_Q, np.array([0.4, 0.0, 0.032]), np.pi / 2)
    wall = (Obstacle("wall", (0.4 + 0.055 + 0.0025, 0.0, 0.03), (0.005, 0.1, 0.06)),)
    full = collision.first_contact(pick, wall)
    assert full is not None and full.link in ("panda_leftfinger", "panda_rightfinger")
    pick.opening = 0.035
    assert collision.first_contact(pick, wall) is None


def test_the_driver_sends_the_opening_with_each_point_of_a_dish_pick_and_place() -> None:
    on_rim = dish("plate_0", ObjectCategory.PLATE, UPRIGHT, 0.4, 0.0)
    s = scene(on_rim)
    pick, place = choose_grasps(s, on_rim, s.goals[0].position)
    arm = PerfectArm()
    driver = PandaMotionDriver(arm)
    driver.pick(Motion("e:1", "plate_0", on_rim.position, on_rim.orientation, pick))
    driver.place(Motion("e:1", "plate_0", s.goals[0].position, ORIENTATIONS[UPRIGHT], place))
    assert len(arm.sent) == 3  # pick, carry, release
    for command in arm.sent:
        assert [p.opening for p in command.points] == pytest.approx([0.035] * len(command.points))
    release = arm.sent[-1]
    assert release.points[-1].gripper is GripperTarget.OPEN
    assert trajectory_of(release).closed[-1] is False


def test_a_bowl_beside_a_plate_on_its_rim_is_taken_high_enough_for_the_hand_to_clear_it() -> None:
    bowl = dish("bowl_0", ObjectCategory.BOWL, 1, 0.4, 0.0)  # 3.5 cm high
    plate = dish("plate_0", ObjectCategory.PLATE, UPRIGHT, 0.4, 0.1)  # 6.4 cm, 10 cm away
    goal = scene().goals[0].position
    alone = choose_grasps(scene(bowl), bowl, goal)[0]
    assert alone.height == 0.0  # at its centre
    beside = choose_grasps(scene(bowl, plate), bowl, goal)
    hand_underside = bowl.position.z + beside[0].height + HAND_ABOVE_TCP
    assert hand_underside > 2 * plate.position.z  # above the plate's top
    # ... yet the fingertips still hold the bowl's top GRIP_DEPTH.
    fingertips = bowl.position.z + beside[0].height - 0.0095
    assert 2 * bowl.position.z - fingertips == pytest.approx(GRIP_DEPTH)
    assert beside[1].height == beside[0].height  # set down as held
    # A plate on its rim next to another is as tall: taken at its centre.
    other = dish("plate_1", ObjectCategory.PLATE, UPRIGHT, 0.4, -0.1)
    assert choose_grasps(scene(plate, other), plate, goal)[0].height == 0.0
