"""PickAndPlace executes tray actions and oriented placements through the gripper driver."""

from __future__ import annotations

import pytest

from manigraph_dishwasher.fixtures import Rack, TrayAction
from manigraph_dishwasher.fixtures import rack as rack_in
from manigraph_dishwasher.fixtures import racks as racks_in
from manigraph_dishwasher.rack_geometry import RACK_TRAVEL
from manigraph_lab.episode_loop import StepClock, gripper_driver
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    Action,
    EpisodeRequest,
    Scene,
    SkillState,
    SkillStatus,
    Vector3,
)
from manigraph_shared.orientations import UPSIDE_DOWN, nearest_orientation
from manigraph_shared.workspace import Workspace
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_skills.drivers.base import Motion, RobotDriver, TrayToggle
from manigraph_skills.pick_and_place import PickAndPlace


def action(step: int, obj: str, goal: str, **extra: object) -> Action:
    return Action(
        decision_id=f"e:{step}",
        episode_id="e",
        scene_sequence=0,
        object_id=obj,
        goal_id=goal,
        policy="test",
        stamp=0.0,
        **extra,  # type: ignore[arg-type]
    )


def test_a_toggle_then_an_oriented_placement_through_the_gripper_driver() -> None:
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=2), 0.0)
    skill = PickAndPlace(gripper_driver(backend, StepClock()), Workspace(), lambda: 0.0)
    reports: list[SkillStatus] = []

    closed = skill.execute(action(0, "bowl_0", "top_bowl_00"), backend.scene(1.0), reports.append)
    assert closed.state is SkillState.FAILED and closed.reason == "rack_closed"

    toggle = action(1, "rack_top", "rack_top", family_action="toggle")
    assert skill.execute(toggle, backend.scene(2.0), reports.append).state is SkillState.SUCCEEDED
    scene = backend.scene(3.0)
    assert scene is not None and rack_in(scene, "rack_top").open

    place = action(2, "bowl_0", "top_bowl_00", orientation_index=UPSIDE_DOWN)
    assert skill.execute(place, scene, reports.append).state is SkillState.SUCCEEDED
    after = backend.scene(4.0)
    assert after is not None
    assert nearest_orientation(after.object("bowl_0").orientation) == UPSIDE_DOWN
    assert after.goal("top_bowl_00").filled
    assert backend.steps == 3  # two picks and a toggle count against the budget


def test_a_tray_action_on_a_block_task_is_refused_by_name() -> None:
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="stack", blocks=2), 0.0)
    skill = PickAndPlace(gripper_driver(backend, StepClock()), Workspace(), lambda: 0.0)
    toggle = action(0, "rack_top", "rack_top", family_action="toggle")
    status = skill.execute(toggle, backend.scene(1.0), lambda _: None)
    assert status.state is SkillState.FAILED and status.reason == "unknown_rack"


class ArmWithoutTrays(RobotDriver):
    name = "arm"

    def pick(self, motion: Motion) -> None: ...

    def place(self, motion: Motion) -> None: ...

    def stop(self) -> None: ...

    def resume(self) -> None: ...


def test_a_driver_without_tray_support_refuses_as_unsupported() -> None:
    with pytest.raises(SkillError) as refused:
        ArmWithoutTrays().toggle_tray(
            TrayToggle("e:0", "rack_top", Vector3(x=0.5, y=0.0, z=0.3), False, 0.16, (0, 0, 0))
        )
    assert refused.value.reason == "unsupported"


def _rack_pulled_out(tray: TrayAction = TrayAction.TOGGLE_TOP) -> Scene:
    """A two-dish geometric episode's scene once ``tray``'s rack (the top one) has been
    pulled out."""
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=2), 0.0)
    skill = PickAndPlace(gripper_driver(backend, StepClock()), Workspace(), lambda: 0.0)
    rack = tray.rack_id
    assert rack is not None
    toggle = action(0, rack, rack, family_action=tray.family_action)
    assert skill.execute(toggle, backend.scene(1.0), lambda _: None).state.value == "succeeded"
    scene = backend.scene(2.0)
    assert scene is not None
    return scene


def test_an_open_rack_floor_supports_a_dish_set_into_its_slot_and_nothing_else() -> None:
    import numpy as np

    from manigraph_skills.obstacles import scene_obstacles

    scene = _rack_pulled_out()
    bowl = scene.object("bowl_0")

    def floor(at: np.ndarray) -> bool:
        (found,) = [o for o in scene_obstacles(scene, bowl, at) if o.id == "rack_top:floor"]
        return found.support

    slot = np.array(scene.goal("top_bowl_00").position.as_tuple())
    on_counter = np.array(bowl.position.as_tuple())
    assert floor(slot)  # set down into the rack: the fingers may come close to its floor
    assert not floor(on_counter)  # taken off the counter below it: the floor is an obstacle
    assert not floor(slot + np.array([0.0, 0.0, 0.10]))  # far above the floor: not under it


def test_a_pushed_in_racks_floor_is_an_obstacle_where_the_rack_stands() -> None:
    """The wrist reaching into the pulled-out bottom rack's far slots met the pushed-in top
    rack's front edge, which the arm check did not know of, and stopped 5 cm short."""
    from manigraph_dishwasher.rack_geometry import RACK_FLOOR_X, RACK_HANDLE_X
    from manigraph_dishwasher.skills.obstacles import rack_obstacles

    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=2), 0.0)
    scene = backend.scene(1.0)
    assert scene is not None
    floors = {o.id: o for o in rack_obstacles(scene) if o.id.endswith(":floor")}
    assert set(floors) == {"rack_top:floor", "rack_bottom:floor"}
    for rack in racks_in(scene):
        assert not rack.open
        front = floors[f"{rack.id}:floor"].centre[0] - floors[f"{rack.id}:floor"].size[0] / 2
        assert front == pytest.approx(rack.position.x - RACK_HANDLE_X + RACK_FLOOR_X[0])


def test_a_dish_of_the_far_row_is_taken_under_a_pulled_out_top_racks_floor() -> None:
    """Carried at the ceiling (0.30 m), the open fingers reaching for a bowl of the counter's
    far row met the pulled-out top rack's front edge on every re-plan; carried low they
    pass under it."""
    from arm_helpers import PerfectArm, trajectory_of

    from manigraph_skills.drivers.panda_motion import PandaMotionDriver
    from manigraph_skills.grasp_choice import choose_grasps
    from manigraph_skills.motion import PandaModel
    from manigraph_skills.motion.collision import ArmCollisionModel

    scene = _rack_pulled_out()
    bowl = scene.object("bowl_0")
    far = Vector3(x=0.46, y=0.08, z=bowl.position.z)  # the physical counter's far row
    bowl = bowl.replace(position=far)
    others = [o for o in scene.objects if o.id != "bowl_0"]
    scene = scene.replace(objects=[*others, bowl])
    slot = scene.goal("top_bowl_00").position
    pick, _ = choose_grasps(scene, bowl, slot)
    arm = PerfectArm()
    PandaMotionDriver(arm).pick(Motion("e:1", bowl.id, bowl.position, bowl.orientation, pick))
    (taken,) = arm.sent
    assert (
        ArmCollisionModel(PandaModel()).first_contact(trajectory_of(taken), pick.obstacles) is None
    )


def test_a_plate_on_its_rim_on_the_far_row_is_taken_under_a_pulled_out_bottom_rack() -> None:
    """A plate standing on its rim with its faces towards the racks is taken across its
    thickness, the hand's 20.8 cm along x. Racks sliding 12 cm left the hand 4 mm short of
    the pulled-out bottom rack's floor at the far row, and such a plate was refused on every
    re-plan (three of ten validation episodes); the physics world's racks slide 11 cm."""
    from arm_helpers import PerfectArm, trajectory_of

    from manigraph_dishwasher.sim.physics import COUNTER_ROWS, PHYSICAL_DISH_SIZE, RAIL
    from manigraph_shared.orientations import ORIENTATIONS
    from manigraph_skills.drivers.panda_motion import PandaMotionDriver
    from manigraph_skills.grasp_choice import choose_grasps
    from manigraph_skills.motion import PandaModel
    from manigraph_skills.motion.collision import ArmCollisionModel

    scene = _rack_pulled_out(TrayAction.TOGGLE_BOTTOM)
    # The bottom rack out as far as the physics world's rail lets it, its slots with it.
    rack = rack_in(scene, "rack_bottom")
    back = RACK_TRAVEL - RAIL
    rack = Rack(rack.id, _moved(rack.position, back), rack.open, travel=RAIL, rail=RAIL)
    goals = [
        g.replace(position=_moved(g.position, back)) if g.fixture == rack.id else g
        for g in scene.goals
    ]
    far_row = COUNTER_ROWS[-1][1] + 0.005  # the far row, at its farthest jitter
    width, _, thickness = PHYSICAL_DISH_SIZE["plate"]
    plate = scene.object("plate_0").replace(
        position=Vector3(x=far_row, y=0.0, z=width / 2),
        orientation=ORIENTATIONS[4],
        size=Vector3(x=width, y=width, z=thickness),
    )
    others = [o for o in scene.objects if o.id != plate.id]
    fixtures = [rack.fixture() if f.id == rack.id else f for f in scene.fixtures]
    scene = scene.replace(objects=[*others, plate], fixtures=fixtures, goals=goals)
    pick, _ = choose_grasps(scene, plate, scene.goal("bottom_plate_05").position)
    arm = PerfectArm()
    PandaMotionDriver(arm).pick(Motion("e:1", plate.id, plate.position, plate.orientation, pick))
    (taken,) = arm.sent
    assert (
        ArmCollisionModel(PandaModel()).first_contact(trajectory_of(taken), pick.obstacles) is None
    )


def _moved(position: Vector3, dx: float) -> Vector3:
    return position.replace(x=position.x + dx)
