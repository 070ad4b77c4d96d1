"""PickAndPlace(object, goal): the primitive the policy's decisions are executed with; with a
tray action (dishwasher), ToggleTray(rack) instead, and an ``orientation_index`` turns the
object to that orientation as it is placed."""

from __future__ import annotations

import time
from collections.abc import Callable

from manigraph_shared.dishwasher_rules import check_dish_move
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import Action, Scene, SkillState, SkillStatus, TrayAction
from manigraph_shared.orientations import orientation
from manigraph_shared.workspace import Workspace
from manigraph_skills.dishwasher.slot_room import set_down_point
from manigraph_skills.drivers.base import Motion, RobotDriver, TrayToggle
from manigraph_skills.grasp_choice import choose_grasps

SKILL = "pick_and_place"


class PickAndPlace:
    def __init__(
        self, driver: RobotDriver, workspace: Workspace, clock: Callable[[], float] = time.time
    ) -> None:
        self.driver = driver
        self.workspace = workspace
        self.clock = clock

    def execute(
        self, action: Action, scene: Scene | None, report: Callable[[SkillStatus], None]
    ) -> SkillStatus:
        """Run ``action`` against the driver, reporting each state; returns the final one."""

        def status(state: SkillState, reason: str | None = None, detail: str = "") -> SkillStatus:
            message = SkillStatus(
                decision_id=action.decision_id,
                skill=SKILL,
                state=state,
                reason=reason,
                detail=detail,
                stamp=self.clock(),
            )
            report(message)
            return message

        status(SkillState.ACCEPTED)
        try:
            if scene is None or scene.episode_id != action.episode_id:
                raise SkillError("no_scene", f"no observation of episode {action.episode_id}")
            if action.tray_action is not TrayAction.NONE:
                self._toggle_tray(action, scene, status)
                return status(SkillState.SUCCEEDED)

            try:
                item = scene.object(action.object_id)
            except KeyError:
                raise SkillError("unknown_object", action.object_id) from None
            try:
                goal = scene.goal(action.goal_id)
            except KeyError:
                raise SkillError("unknown_goal", action.goal_id) from None
            for name, point in (("object", item.position), ("goal", goal.position)):
                if not self.workspace.contains(point):
                    raise SkillError("outside_workspace", f"{name} at {point.as_tuple()}")
            turn = goal.orientation
            if action.orientation_index is not None:
                turn = orientation(action.orientation_index)
            if scene.racks and self.driver.checks_dish_rules:
                check_dish_move(scene, item, goal)
            if action.orientation_index is not None:
                self.driver.check_orientation(item.id, item.orientation, turn)
            status(SkillState.RUNNING)
            decision = action.decision_id
            if action.orientation_index is not None:
                turned = self.driver.turn_over(decision, item, turn, scene)
                if turned is not item:
                    scene = scene.model_copy(
                        update={
                            "objects": [turned if o.id == item.id else o for o in scene.objects]
                        }
                    )
                    item = turned
            target = set_down_point(scene, item, goal) if scene.racks else goal.position
            pick, place = choose_grasps(scene, item, target)
            self.driver.pick(Motion(decision, item.id, item.position, item.orientation, pick))
            self.driver.place(Motion(decision, item.id, target, turn, place))
        except SkillError as exc:
            return status(SkillState.FAILED, exc.reason, exc.detail)
        return status(SkillState.SUCCEEDED)

    def _toggle_tray(
        self, action: Action, scene: Scene, status: Callable[[SkillState], SkillStatus]
    ) -> None:
        """ToggleTray: the rack the tray action names, if the scene has it."""
        rack_id = action.tray_action.rack_id
        assert rack_id is not None
        try:
            rack = scene.rack(rack_id)
        except KeyError:
            raise SkillError("unknown_rack", f"the scene has no {rack_id}") from None
        if not self.workspace.contains(rack.position):
            raise SkillError("outside_workspace", f"{rack_id} handle at {rack.position.as_tuple()}")
        status(SkillState.RUNNING)
        self.driver.toggle_tray(
            TrayToggle(
                action.decision_id, rack_id, rack.position, rack.open, rack.travel, rack.rail
            )
        )
