"""PickAndPlace(object, goal): the primitive the policy's decisions are executed with. An
action a task family owns (one that is not a pick and place) is run by that family's extension
(``family``: ``SkillFamily.run_action``), and an ``orientation_index`` turns the object to
that orientation as it is placed. Where the object is set down, and which rules a robot
whose world refuses nothing checks first, are the scene's family's."""

from __future__ import annotations

import time
from collections.abc import Callable

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    Action,
    Scene,
    SceneGoal,
    SceneObject,
    SkillState,
    SkillStatus,
)
from manigraph_shared.orientations import orientation
from manigraph_shared.workspace import Workspace
from manigraph_skills.drivers.base import Motion, RobotDriver
from manigraph_skills.family import family_of, family_taking
from manigraph_skills.grasp_choice import choose_grasps

SKILL = "pick_and_place"


class PickAndPlace:
    def __init__(
        self, driver: RobotDriver, workspace: Workspace, clock: Callable[[], float] = time.time
    ) -> None:
        self.driver = driver
        self.workspace = workspace
        self.clock = clock

    def object_and_goal(self, action: Action, scene: Scene) -> tuple[SceneObject, SceneGoal]:
        """The action's object and goal in ``scene``, both within the workspace
        (``SkillError``: ``unknown_object``, ``unknown_goal``, ``outside_workspace``); a
        family's own place action checks its pair the same way."""
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
        return item, goal

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
            owner = family_taking(action)
            if owner is not None:  # e.g. a tray action: its family runs it
                owner.part("run_action")(self, action, scene, status)
                return status(SkillState.SUCCEEDED)

            item, goal = self.object_and_goal(action, scene)
            turn = goal.orientation
            if action.orientation_index is not None:
                turn = orientation(action.orientation_index)
            family = family_of(scene)
            rules = family.part("check_move")
            if rules is not None and self.driver.checks_family_rules:
                rules(scene, item, goal)
            if action.orientation_index is not None:
                self.driver.check_orientation(item.id, item.orientation, turn)
            status(SkillState.RUNNING)
            decision = action.decision_id
            if action.orientation_index is not None:
                turned = self.driver.turn_over(decision, item, turn, scene)
                if turned is not item:
                    scene = scene.replace(
                        objects=[turned if o.id == item.id else o for o in scene.objects]
                    )
                    item = turned
            set_down = family.part("set_down_point")
            target = goal.position if set_down is None else set_down(scene, item, goal)
            pick, place = choose_grasps(scene, item, target)
            self.driver.pick(Motion(decision, item.id, item.position, item.orientation, pick))
            self.driver.place(Motion(decision, item.id, target, turn, place))
        except SkillError as exc:
            return status(SkillState.FAILED, exc.reason, exc.detail)
        return status(SkillState.SUCCEEDED)
