"""PickAndPlace(object, goal): the primitive the policy's decisions are executed with."""

from __future__ import annotations

import time
from collections.abc import Callable

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import Action, Scene, SkillState, SkillStatus, TrayAction
from manigraph_skills.drivers.base import Motion, RobotDriver
from manigraph_skills.grasp_choice import choose_grasps
from manigraph_skills.workspace import Workspace

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
            if action.tray_action is not TrayAction.NONE:
                raise SkillError("unsupported", f"{action.tray_action} needs a tray driver")
            if scene is None or scene.episode_id != action.episode_id:
                raise SkillError("no_scene", f"no observation of episode {action.episode_id}")
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
            status(SkillState.RUNNING)
            pick, place = choose_grasps(scene, item, goal.position)
            decision = action.decision_id
            self.driver.pick(Motion(decision, item.id, item.position, item.orientation, pick))
            self.driver.place(Motion(decision, item.id, goal.position, goal.orientation, place))
        except SkillError as exc:
            return status(SkillState.FAILED, exc.reason, exc.detail)
        return status(SkillState.SUCCEEDED)
