"""The dishwasher in SAPIEN: real racks on prismatic joints, real dishes, the Panda driver's
ToggleTray and PickAndPlace, the geometric world's rules, success and Scene shape."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest
import sapien

from manigraph_dishwasher.fixtures import rack as rack_in
from manigraph_dishwasher.fixtures import racks
from manigraph_dishwasher.sim.physics import PHYSICAL_DISH_SIZE, RAIL, physical_counter_x
from manigraph_dishwasher.skills.turn_over import quaternion_of
from manigraph_lab.episode_loop import panda_driver, run_episode
from manigraph_planner.policies.base import load_policy
from manigraph_shared.messages import (
    Action,
    EpisodeRequest,
    Quaternion,
    Scene,
    SkillState,
    SkillStatus,
)
from manigraph_shared.orientations import ORIENTATIONS, UPSIDE_DOWN, up_axis_orientation
from manigraph_shared.rotations import rotation_matrix
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.physics.backend import PhysicsBackend

#: Seed 8, 10 dishes: bowl_3 lies upside down and plate_3 stands on its rim (x >= 0.3 m), so
#: both can be loaded by top-down grasps. (Found by listing layouts; no outcome is tuned.)
SEED = 8


Loop = Any  # tests/physics/conftest.py: InProcessLoop


class DishLoop:
    """The conftest's in-process loop with dishwasher actions."""

    def __init__(self, loop: Loop) -> None:
        self.loop = loop
        self.backend: PhysicsBackend = loop.backend

    def scene(self) -> Scene:
        return self.loop.scene()

    def act(self, obj: str, goal: str, **extra: object) -> SkillStatus:
        scene = self.scene()
        self.loop.decisions += 1
        action = Action(
            decision_id=f"{scene.episode_id}:{self.loop.decisions}",
            episode_id=scene.episode_id,
            scene_sequence=scene.sequence,
            object_id=obj,
            goal_id=goal,
            policy="test",
            stamp=time.time(),
            **extra,  # type: ignore[arg-type]
        )
        status = self.loop.skill.execute(action, scene, lambda _status: None)
        self.backend.skill_finished(status)
        return status

    def toggle(self, rack: str) -> SkillStatus:
        return self.act(rack, rack, family_action="toggle")


@pytest.fixture
def dish_loop(loop: Loop) -> DishLoop:
    loop.backend.reset(
        EpisodeRequest(episode_id="d", task="dishwasher", objects=10, seed=SEED), time.time()
    )
    return DishLoop(loop)


def _position(scene: Scene, object_id: str) -> np.ndarray:
    return np.array(scene.object(object_id).position.as_tuple())


def test_the_physics_scene_has_the_geometric_worlds_shape() -> None:
    request = EpisodeRequest(episode_id="d", task="dishwasher", objects=10, seed=SEED)
    physics, geometric = PhysicsBackend(), GeometricBackend()
    physics.reset(request, 0.0)
    geometric.reset(request, 0.0)
    ours, theirs = physics.scene(1.0), geometric.scene(1.0)
    assert ours is not None and theirs is not None
    assert [g.id for g in ours.goals] == [g.id for g in theirs.goals]
    # Slots and handles where the racks physically are: the geometric world's, to a hair.
    assert [(g.orientation, g.fixture) for g in ours.goals] == [
        (g.orientation, g.fixture) for g in theirs.goals
    ]
    for mine_goal, their_goal in zip(ours.goals, theirs.goals, strict=True):
        assert mine_goal.position.as_tuple() == pytest.approx(their_goal.position.as_tuple())
    assert [(r.id, r.open) for r in racks(ours)] == [(r.id, r.open) for r in racks(theirs)]
    for mine_rack, their_rack in zip(racks(ours), racks(theirs), strict=True):
        assert mine_rack.position.as_tuple() == pytest.approx(their_rack.position.as_tuple())
    for mine, other in zip(ours.objects, theirs.objects, strict=True):
        assert mine.id == other.id and mine.orientation == other.orientation
        # The physical counter is the geometric one moved out of the arm's blind spot.
        x, y, _ = other.position.as_tuple()
        assert np.allclose(mine.position.as_tuple()[:2], (physical_counter_x(x), y), atol=0.006)
        assert mine.size.as_tuple() == PHYSICAL_DISH_SIZE[mine.category.value]


def test_racks_slide_out_and_in_on_their_rails_with_the_dishes_in_them(
    dish_loop: DishLoop,
) -> None:
    world = dish_loop.backend.task_world
    assert world is not None
    assert dish_loop.toggle("rack_top").state is SkillState.SUCCEEDED
    assert world.rack_travel("rack_top") == pytest.approx(RAIL, abs=0.005)
    assert world.rack_travel("rack_bottom") == pytest.approx(0.0, abs=0.002)
    # Out all the way on its rail, which the scene reports (12 cm: docs/dishwasher.md).
    assert rack_in(dish_loop.scene(), "rack_top").open
    assert rack_in(dish_loop.scene(), "rack_top").rail == pytest.approx(RAIL)

    loaded = dish_loop.act("bowl_3", "top_bowl_07", orientation_index=UPSIDE_DOWN)
    assert loaded.state is SkillState.SUCCEEDED, loaded
    before = _position(dish_loop.scene(), "bowl_3")
    assert dish_loop.toggle("rack_top").state is SkillState.SUCCEEDED
    assert world.rack_travel("rack_top") == pytest.approx(0.0, abs=0.005)
    scene = dish_loop.scene()
    after = _position(scene, "bowl_3")
    # The bowl rode in with its rack, still upside down and in its slot.
    assert after - before == pytest.approx([RAIL, 0.0, 0.0], abs=0.01)
    assert scene.object("bowl_3").filled and scene.goal("top_bowl_07").filled
    assert up_axis_orientation(scene.object("bowl_3").orientation) == UPSIDE_DOWN
    assert not rack_in(scene, "rack_top").open


def test_the_loading_rules_refuse_before_any_motion(dish_loop: DishLoop) -> None:
    backend = dish_loop.backend
    joints = backend.world.arm_q.copy()  # type: ignore[union-attr]

    def refused(status: SkillStatus, reason: str) -> None:
        assert status.state is SkillState.FAILED and status.reason == reason, status
        assert np.allclose(backend.world.arm_q, joints, atol=0.01)  # type: ignore[union-attr]

    refused(dish_loop.act("bowl_3", "top_bowl_07", orientation_index=1), "rack_closed")
    assert dish_loop.toggle("rack_bottom").state is SkillState.SUCCEEDED
    assert dish_loop.toggle("rack_top").state is SkillState.SUCCEEDED
    joints = backend.world.arm_q.copy()  # type: ignore[union-attr]
    # Both racks out: the open top rack is in the way of the bottom one.
    refused(dish_loop.act("plate_3", "bottom_plate_00", orientation_index=2), "top_rack_open")
    refused(dish_loop.act("plate_3", "top_bowl_00", orientation_index=2), "wrong_slot")
    assert dish_loop.act("bowl_3", "top_bowl_07", orientation_index=1).state is (
        SkillState.SUCCEEDED
    )
    joints = backend.world.arm_q.copy()  # type: ignore[union-attr]
    refused(dish_loop.act("bowl_0", "top_bowl_07", orientation_index=1), "slot_taken")


#: Seed 16, 2 dishes: plate_0 stands on its rim and bowl_0 lies upside down, both where a
#: top-down grasp reaches them (found by listing layouts, not by running episodes).
SHORT_SEED = 16


def test_the_expert_loads_a_two_dish_episode_in_physics() -> None:
    """The scripted expert decides, the Panda driver toggles and places, and
    the episode ends as in the geometric world: both dishes in preferred slots in their
    orientations, both racks pushed in."""
    policy = load_policy("dishwasher-top-bottom")
    request = EpisodeRequest(
        episode_id="s",
        task="dishwasher",
        objects=2,
        seed=SHORT_SEED,
        options={"preference": "top-bottom"},
    )
    record = run_episode(
        policy,
        request,
        backend_factory=PhysicsBackend,
        driver_factory=panda_driver,
    )
    assert record.end.success, [
        (s.action.object_id, s.action.goal_id, s.reason) for s in record.steps
    ]
    # Pull top, bowl, push top, pull bottom, plate, push bottom: no step wasted.
    assert len(record.steps) == 6
    assert [s.action.family_action for s in record.steps].count(None) == 2


#: Validation seed 1000, 10 dishes: bowl_1 lies on its side (+x up) in the counter's middle,
#: between other dishes. (Found by listing layouts; no outcome is tuned.)
TURN_SEED = 1000


def test_a_bowl_on_its_side_is_turned_over_into_its_slot(loop: Loop) -> None:
    """The turn-over manoeuvre: a top-down grasp alone cannot turn a bowl lying on its side
    upside down; the driver tilts it on the counter (the hand sideways), takes it top-down
    again and loads it upside down."""
    loop.backend.reset(
        EpisodeRequest(episode_id="t", task="dishwasher", objects=10, seed=TURN_SEED), time.time()
    )
    dishes = DishLoop(loop)
    assert up_axis_orientation(dishes.scene().object("bowl_1").orientation) == 4
    assert dishes.toggle("rack_top").state is SkillState.SUCCEEDED
    loaded = dishes.act("bowl_1", "top_bowl_00", orientation_index=UPSIDE_DOWN)
    assert loaded.state is SkillState.SUCCEEDED, loaded
    scene = dishes.scene()
    assert up_axis_orientation(scene.object("bowl_1").orientation) == UPSIDE_DOWN
    assert scene.object("bowl_1").filled and scene.goal("top_bowl_00").filled


def test_a_bowl_left_in_the_rack_in_no_slot_is_taken_to_the_counter_and_turned_there(
    loop: Loop,
) -> None:
    """A placement that missed leaves a bowl lying in the pulled-out rack between the slots,
    on its side. The rack's floor and slots leave no room to tilt it there (every re-plan
    was refused, and the episode spent its budget toggling racks), so it is carried to a
    free counter cell, turned over there and loaded."""
    loop.backend.reset(
        EpisodeRequest(episode_id="t", task="dishwasher", objects=10, seed=TURN_SEED), time.time()
    )
    dishes = DishLoop(loop)
    assert dishes.toggle("rack_top").state is SkillState.SUCCEEDED
    slot = dishes.scene().goal("top_bowl_01")
    entity = loop.backend.world.entities["bowl_1"]
    lying = _sapien_pose_quaternion(ORIENTATIONS[4])  # on its side
    half = PHYSICAL_DISH_SIZE["bowl"][0] / 2
    entity.set_pose(
        sapien.Pose([slot.position.x, slot.position.y + 0.035, slot.position.z + half], lying)
    )
    loop.backend.world.step(300)
    scene = dishes.scene()
    bowl = scene.object("bowl_1")
    assert bowl.position.z > 0.1 and not bowl.filled  # in the rack, in no slot
    assert up_axis_orientation(bowl.orientation) != UPSIDE_DOWN
    loaded = dishes.act("bowl_1", "top_bowl_03", orientation_index=UPSIDE_DOWN)
    assert loaded.state is SkillState.SUCCEEDED, loaded
    scene = dishes.scene()
    assert up_axis_orientation(scene.object("bowl_1").orientation) == UPSIDE_DOWN
    assert scene.object("bowl_1").filled and scene.goal("top_bowl_03").filled


def _sapien_pose_quaternion(q: Quaternion) -> list[float]:
    return [q.w, q.x, q.y, q.z]


def test_a_rack_part_of_the_way_out_is_seen_where_it_is_and_clicks_to_the_nearer_end(
    dish_loop: DishLoop,
) -> None:
    world = dish_loop.backend.task_world
    assert world is not None
    closed = dish_loop.scene()
    top = world.rails["rack_top"]
    for travel, settles_at in ((0.08, RAIL), (0.04, 0.0)):
        qpos = world.cabinet.qpos.copy()
        qpos[list(world.rails).index("rack_top")] = -travel
        world.cabinet.set_qpos(qpos)
        seen = dish_loop.scene()
        rack = rack_in(seen, "rack_top")
        # Where it is, as a camera would see it: its handle and its slots moved that far.
        assert rack.travel == pytest.approx(travel, abs=1e-4)
        assert rack.open == (travel > RAIL / 2)
        moved = rack.position.x - rack_in(closed, "rack_top").position.x
        assert moved == pytest.approx(-travel, abs=1e-4)
        slot = seen.goal("top_bowl_07").position.x - closed.goal("top_bowl_07").position.x
        assert slot == pytest.approx(-travel, abs=1e-4)
        # Left alone, the rack's detent takes it to the end of the rail it is nearer.
        dish_loop.backend.world.step(500)  # type: ignore[union-attr]
        assert world.rack_travel("rack_top") == pytest.approx(settles_at, abs=0.01), top


def test_a_plate_on_its_rim_in_its_slot_is_loaded_whichever_edge_is_down() -> None:
    """The physical plate is square about its thin axis (a round plate's stand-in): stood in
    its slot between the ribs on another edge ("side-x", as a plate that pivoted between the
    fingers is), it is loaded upright all the same."""
    backend = PhysicsBackend()
    request = EpisodeRequest(
        episode_id="r",
        task="dishwasher",
        objects=2,
        seed=SHORT_SEED,
        options={"preference": "top-bottom"},
    )
    backend.reset(request, 1.0)
    scene = backend.scene(1.0)
    assert scene is not None
    plate = next(o for o in scene.objects if o.category.value == "plate")
    slot = next(g for g in scene.goals if g.id.startswith("bottom_plate"))
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    side_x = quaternion_of(quarter @ rotation_matrix(ORIENTATIONS[4]))  # thin axis along y
    assert rotation_matrix(side_x)[:, 2] == pytest.approx([0.0, -1.0, 0.0], abs=1e-9)
    pose = sapien.Pose(
        np.array(slot.position.as_tuple()) + np.array([0.0, 0.0, 0.002]),
        [side_x.w, side_x.x, side_x.y, side_x.z],
    )
    backend.world.entities[plate.id].set_pose(pose)
    backend.world.step(60)  # let it settle between the ribs
    _, (x, y, z, w) = backend.world.pose(plate.id)
    assert up_axis_orientation(Quaternion(x=x, y=y, z=z, w=w)) == 4  # still on that edge
    scene = backend.scene(2.0)
    assert scene is not None and scene.object(plate.id).filled and scene.goal(slot.id).filled
    assert up_axis_orientation(scene.object(plate.id).orientation) == 2  # upright, as asked
    assert plate.id in backend.evaluation().filled_goals


#: Seed 15012 (issue 33, the seventh round's one failure), 10 dishes: bowl_3 lies on its side
#: and is turned over, then set into top_bowl_02; the policy sets bowl_2 beside it next.
KNOCK_SEED = 15012


def test_a_bowl_set_down_beside_a_turned_one_knocks_neither_off_its_slot(loop: Loop) -> None:
    """Issue 33: slots 5.5 cm apart for 5 cm bowls leave 2.5 mm a side. Let go of sideways
    by its turn-over, bowl_3 came to rest turned 13 degrees about the vertical and was set
    into its slot so, reaching 3 mm past its half of the row; bowl_2, set down at its slot's
    centre beside it, met its corner on the way down and knocked it 23 mm off its slot. The
    scene shows the turn, and bowl_2 is set down where its neighbour leaves it room: both
    stay within 10 mm of their slots."""
    loop.backend.reset(
        EpisodeRequest(episode_id="k", task="dishwasher", objects=10, seed=KNOCK_SEED),
        time.time(),
    )
    dishes = DishLoop(loop)
    dishwasher = loop.backend.task_world
    assert dishwasher is not None
    assert dishes.toggle("rack_top").state is SkillState.SUCCEEDED
    first = dishes.act("bowl_3", "top_bowl_02", orientation_index=UPSIDE_DOWN)
    assert first.state is SkillState.SUCCEEDED, first
    # How far a bowl let go of sideways ends up turned is chaotic: 13 degrees in the issue's
    # run, 3.5 in one full test run (whose world had inherited ManiSkill's PhysX defaults,
    # before worlds set their own: physics_world.use_own_physx_defaults). The turn that
    # caused the knock is set here, about the bowl's own centre, and the world settles, so
    # the placement beside it is tested whatever the turn-over gave.
    world = loop.backend.world
    assert world is not None
    bowl = world.entities["bowl_3"]
    pose = bowl.get_pose()
    scene_turn = rotation_matrix(dishes.scene().object("bowl_3").orientation)
    wanted = np.radians(13.0) - np.arctan2(scene_turn[1, 0], scene_turn[0, 0])
    about_z = sapien.Pose(q=[np.cos(wanted / 2), 0.0, 0.0, np.sin(wanted / 2)])
    bowl.set_pose(sapien.Pose(pose.p, (about_z * sapien.Pose(q=pose.q)).q))
    world.step(round(0.5 / world.config.timestep))
    turned = rotation_matrix(dishes.scene().object("bowl_3").orientation)
    assert abs(np.degrees(np.arctan2(turned[1, 0], turned[0, 0]))) % 90 > 10  # seen turned
    second = dishes.act("bowl_2", "top_bowl_03", orientation_index=UPSIDE_DOWN)
    assert second.state is SkillState.SUCCEEDED, second
    scene = dishes.scene()
    assert scene.object("bowl_3").filled and scene.object("bowl_2").filled
    offsets = dishwasher.slot_offsets()
    assert offsets["bowl_3"] <= 10.0 and offsets["bowl_2"] <= 10.0, offsets
