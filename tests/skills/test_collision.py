"""Arm-link collision checking on constructed scenes: the Panda's URDF collision meshes
against blocks, towers, box walls and the table, and the driver's re-planning around them."""

from __future__ import annotations

import re

import numpy as np
import pytest
from arm_helpers import PerfectArm, block, trajectory_of

from manigraph_blocks.skills.obstacles import box_walls
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Quaternion,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_skills.drivers.base import Motion
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.grasp_choice import choose_grasps
from manigraph_skills.motion import HOME_Q, GraspPlanner, IKSolver, JointTrajectory, PandaModel
from manigraph_skills.motion.collision import ESCAPE_TIME, ArmCollisionModel, LinkSpheres
from manigraph_skills.motion.model import top_down
from manigraph_skills.obstacles import Obstacle


def tower(name: str, x: float, y: float, height: int) -> list[SceneObject]:
    return [block(f"{name}_{i}", x, y, i) for i in range(height)]


def scene(*objects: SceneObject, goals: tuple[SceneGoal, ...] = ()) -> Scene:
    return Scene(episode_id="e", stamp=1.0, sequence=0, objects=list(objects), goals=list(goals))


@pytest.fixture(scope="module")
def collision() -> ArmCollisionModel:
    return ArmCollisionModel(PandaModel())


def test_a_plain_pick_touches_nothing_not_even_the_table(collision: ArmCollisionModel) -> None:
    planner = GraspPlanner(collision_model_panda := PandaModel())
    assert collision_model_panda is not None
    pick = planner.pick(HOME_Q, np.array([0.5, 0.1, 0.02]), np.pi / 2)
    assert collision.first_contact(pick) is None


def test_a_hand_below_the_table_top_touches_the_table(collision: ArmCollisionModel) -> None:
    planner = GraspPlanner(PandaModel())
    pick = planner.pick(HOME_Q, np.array([0.5, 0.1, 0.0]), np.pi / 2)
    contact = collision.first_contact(pick)
    assert contact is not None and contact.obstacle == "table"


def test_a_tower_on_the_path_is_found_between_the_planned_points(
    collision: ArmCollisionModel,
) -> None:
    # Two configurations on either side of a thin pole: neither touches it, the sweep does.
    start, end = HOME_Q.copy(), HOME_Q.copy()
    start[0], end[0] = -0.6, 0.6
    sweep = JointTrajectory()
    sweep.add(0.0, start, False)
    sweep.add(1.0, end, False)
    hand = PandaModel().tcp_pose(HOME_Q).translation
    pole = (Obstacle("pole", (hand[0], hand[1], 0.3), (0.01, 0.01, 0.6)),)
    assert collision.touching(start, pole) == [] and collision.touching(end, pole) == []
    contact = collision.first_contact(sweep, pole)
    assert contact is not None and contact.obstacle == "pole" and 0.0 < contact.time < 1.0


def _hand_at(x: float, y: float, z: float) -> tuple[GraspPlanner, JointTrajectory]:
    """A trajectory starting with the hand top-down, TCP at (x, y, z)."""
    planner = GraspPlanner(PandaModel())
    q = planner.ik.solve_or_raise(top_down(np.array([x, y, z]), np.pi / 2), HOME_Q, "start")
    return planner, JointTrajectory([0.0], [q], [False])


#: A slab the open fingers reach into when the TCP is 5 mm above its top at (0.5, 0.1).
SLAB = (Obstacle("slab", (0.5, 0.1, 0.05), (0.3, 0.3, 0.04)),)


def test_a_pair_touching_at_the_start_may_move_apart(collision: ArmCollisionModel) -> None:
    planner, start = _hand_at(0.5, 0.1, 0.075)
    assert {c.obstacle for c in collision.touching(start.final, SLAB)} == {"slab"}
    planner.line(start, [0.5, 0.1, 0.2], np.pi / 2, False, 0.2, "rise")
    assert collision.first_contact(start, SLAB) is None


def test_a_pair_touching_at_the_start_must_not_stay_touching(
    collision: ArmCollisionModel,
) -> None:
    planner, drag = _hand_at(0.5, 0.1, 0.075)
    # Along the slab, still in it, for longer than the escape allows.
    planner.line(drag, [0.5, -0.03, 0.075], np.pi / 2, False, 0.05, "drag")
    assert drag.duration > ESCAPE_TIME
    contact = collision.first_contact(drag, SLAB)
    assert contact is not None and contact.obstacle == "slab"
    assert contact.time == pytest.approx(ESCAPE_TIME, abs=0.1)


def test_a_pair_that_came_apart_touches_again_as_any_other(
    collision: ArmCollisionModel,
) -> None:
    planner, back = _hand_at(0.5, 0.1, 0.075)
    planner.line(back, [0.5, 0.1, 0.2], np.pi / 2, False, 0.2, "rise")
    risen = back.duration
    planner.line(back, [0.5, 0.1, 0.075], np.pi / 2, False, 0.5, "down again")
    contact = collision.first_contact(back, SLAB)
    assert contact is not None and contact.obstacle == "slab" and contact.time > risen


def test_a_tall_tower_beside_the_path_is_passed_higher_or_turned(
    collision: ArmCollisionModel,
) -> None:
    item = block("block_0", 0.5, 0.1)
    world = scene(item, *tower("tower", 0.3, 0.05, 8))
    pick, _ = choose_grasps(world, item, Vector3(x=0.4, y=-0.2, z=0.02))
    planner = GraspPlanner(PandaModel())
    default = planner.pick(HOME_Q, np.array(item.position.as_tuple()), np.pi / 2)
    assert collision.first_contact(default, pick.obstacles) is not None  # as planned: a hit
    arm = PerfectArm()
    PandaMotionDriver(arm).pick(Motion("e:0", item.id, item.position, item.orientation, pick))
    (sent,) = arm.sent
    assert collision.first_contact(trajectory_of(sent), pick.obstacles) is None
    replanned = trajectory_of(sent)  # a different plan went to the arm: higher or turned
    assert len(replanned) != len(default) or not np.allclose(replanned.final, default.final)


def test_a_target_walled_in_by_towers_is_refused_as_collision_before_any_motion() -> None:
    item = block("block_0", 0.5, 0.1)
    walls = [*tower("left", 0.5, 0.1 - 0.045, 12), *tower("right", 0.5, 0.1 + 0.045, 12)]
    walls += [*tower("front", 0.5 - 0.045, 0.1, 12), *tower("back", 0.5 + 0.045, 0.1, 12)]
    world = scene(item, *walls)
    pick, _ = choose_grasps(world, item, Vector3(x=0.4, y=-0.2, z=0.02))
    arm = PerfectArm()
    with pytest.raises(SkillError) as caught:
        PandaMotionDriver(arm).pick(Motion("e:0", item.id, item.position, item.orientation, pick))
    assert caught.value.reason == "collision"
    assert caught.value.detail.startswith("taking it: ")  # which motion of the skill
    # What refused the re-plans too, each link and tower once: turned a quarter, the
    # fingers meet the other pair of towers.
    touched = re.findall(r"(panda_\w+) would touch (\w+)", caught.value.detail)
    assert len(touched) == len(set(touched)) >= 2, caught.value.detail
    towers = {obstacle.split("_")[0] for _, obstacle in touched}
    assert towers & {"left", "right"} and towers & {"front", "back"}, caught.value.detail
    assert arm.sent == []


def test_the_moved_block_and_its_support_are_not_obstacles_to_the_hand(
    collision: ArmCollisionModel,
) -> None:
    stack = tower("stack", 0.5, 0.1, 3)
    item = stack[-1]
    world = scene(*stack)
    goal = Vector3(x=0.4, y=-0.2, z=0.02)
    pick, place = choose_grasps(world, item, goal)
    ids = {o.id: o for o in pick.obstacles}
    assert item.id not in ids  # between the fingers
    assert ids["stack_1"].support and not ids["stack_0"].support
    arm = PerfectArm()
    driver = PandaMotionDriver(arm)
    driver.pick(Motion("e:0", item.id, item.position, item.orientation, pick))
    driver.place(Motion("e:0", item.id, goal, Quaternion(), place))
    assert len(arm.sent) == 3


def test_boxes_are_walls_under_their_cover_goals() -> None:
    cover = SceneObject(
        id="cover_0",
        category=ObjectCategory.COVER,
        position=Vector3(x=0.3, y=0.3, z=0.005),
        size=Vector3(x=0.25, y=0.25, z=0.01),
    )
    goal = SceneGoal(
        id="goal_c", category=GoalCategory.COVER, position=Vector3(x=0.5, y=0, z=0.055)
    )
    walls = box_walls(scene(cover, goals=(goal,)))
    assert len(walls) == 4
    assert all(abs(w.size[2] - 0.05) < 1e-9 and abs(w.centre[2] - 0.025) < 1e-9 for w in walls)
    assert {round(w.centre[0], 3) for w in walls} == {0.38, 0.5, 0.62}


def test_a_forearm_over_a_tower_before_a_far_low_grasp_swings_its_elbow_aside(
    collision: ArmCollisionModel,
) -> None:
    # Six-block stacking, seed 1: the goal tower stands 15 cm in front of the last block.
    # Higher or turned, the forearm still sweeps the tower's top; the elbow swung aside clears.
    item = block("block_0", 0.505, 0.315)
    world = scene(item, *tower("goal", 0.358, 0.314, 5))
    pick, _ = choose_grasps(world, item, Vector3(x=0.358, y=0.314, z=0.22))
    planner = GraspPlanner(PandaModel())
    planned = planner.pick(HOME_Q, np.array(item.position.as_tuple()), np.pi / 2)
    contact = collision.first_contact(planned, pick.obstacles)
    assert contact is not None and contact.link == "panda_link5"
    arm = PerfectArm()
    PandaMotionDriver(arm).pick(Motion("e:0", item.id, item.position, item.orientation, pick))
    (sent,) = arm.sent
    assert collision.first_contact(trajectory_of(sent), pick.obstacles) is None
    assert np.allclose(PandaModel().tcp_pose(arm.q).translation, [0.505, 0.315, 0.1], atol=1e-3)


def test_from_above_the_tower_a_short_motion_swings_the_elbow_harder(
    collision: ArmCollisionModel,
) -> None:
    # The same episode a move later: the hand has just released on the tower (5 high) and
    # goes out to the block beside it; a gentle swing adds up too little over so short a path.
    item = block("block_0", 0.505, 0.315)
    world = scene(item, *tower("goal", 0.357, 0.314, 5))
    pick, _ = choose_grasps(world, item, Vector3(x=0.357, y=0.314, z=0.22))
    model = PandaModel()
    arm = PerfectArm()
    arm.q = IKSolver(model).solve_or_raise(
        top_down(np.array([0.357, 0.314, 0.3]), np.pi / 2), HOME_Q, "start"
    )
    planned = GraspPlanner(model).pick(arm.q, np.array(item.position.as_tuple()), np.pi / 2)
    assert collision.first_contact(planned, pick.obstacles) is not None
    PandaMotionDriver(arm).pick(Motion("e:0", item.id, item.position, item.orientation, pick))
    (sent,) = arm.sent
    assert collision.first_contact(trajectory_of(sent), pick.obstacles) is None


def _random_boxes(rng: np.random.Generator, count: int) -> tuple[Obstacle, ...]:
    """Boxes of 2-30 cm, some turned about the vertical, scattered over the arm's reach."""
    boxes = []
    for i in range(count):
        yaw = rng.uniform(0, np.pi) if i % 2 else 0.0
        boxes.append(
            Obstacle(
                f"box_{i}",
                (rng.uniform(0.2, 0.8), rng.uniform(-0.5, 0.5), rng.uniform(0.0, 0.5)),
                tuple(rng.uniform(0.02, 0.3, 3).tolist()),
                (0.0, 0.0, float(np.sin(yaw / 2)), float(np.cos(yaw / 2))),
                support=bool(i % 5 == 0),
            )
        )
    return tuple(boxes)


def test_checking_only_the_near_pairs_finds_what_checking_every_pair_finds(
    collision: ArmCollisionModel, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bounding-sphere pre-filter (``LinkSpheres``) leaves out only pairs that cannot
    touch over a segment: over random picks, places and joint sweeps among random boxes,
    every first contact (link, obstacle, time), and every clear motion, is the same as with
    every pair checked at every sample."""
    rng = np.random.default_rng(7)
    planner = GraspPlanner(PandaModel())
    cases: list[tuple[JointTrajectory, tuple[Obstacle, ...]]] = []
    while len(cases) < 40:
        boxes = _random_boxes(rng, int(rng.integers(3, 12)))
        target = np.array([rng.uniform(0.3, 0.6), rng.uniform(-0.4, 0.4), rng.uniform(0.02, 0.2)])
        try:
            if len(cases) % 3 == 2:
                trajectory = JointTrajectory()
                trajectory.add(0.0, HOME_Q, False)
                trajectory.add(1.0, HOME_Q + rng.uniform(-1.0, 1.0, 7), False)
            else:
                trajectory = planner.pick(HOME_Q, target, rng.uniform(-np.pi, np.pi))
        except SkillError:
            continue
        cases.append((trajectory, boxes))
    found = [collision.first_contact(t, boxes) for t, boxes in cases]
    assert 5 < sum(c is None for c in found) < len(found) - 5  # both kinds are exercised

    def every_pair(self: LinkSpheres, data: object, qa: object, qb: object) -> np.ndarray:
        return np.ones(len(self.first), dtype=bool)

    monkeypatch.setattr(LinkSpheres, "near", every_pair)
    assert [collision.first_contact(t, boxes) for t, boxes in cases] == found
