"""The skills service: executes planner decisions with the configured robot driver."""

from __future__ import annotations

from manigraph_shared.bus import Bus
from manigraph_shared.messages import Action, Scene
from manigraph_shared.service import Service
from manigraph_skills.drivers.base import RobotDriver
from manigraph_skills.pick_and_place import PickAndPlace
from manigraph_skills.scene_cache import SceneCache
from manigraph_skills.workspace import Workspace


class SkillsService(Service):
    name = "skills"

    def __init__(self, bus: Bus, driver_factory, workspace: Workspace) -> None:
        super().__init__(bus)
        self.driver: RobotDriver = driver_factory(bus)
        self.skill = PickAndPlace(self.driver, workspace)
        self.scenes = SceneCache()

    def setup(self) -> None:
        # Scenes bypass the inbox: an action waits for the scene it was decided on.
        self.bus.subscribe(Scene, self.scenes.update, on_error=self._rejected)
        self.on(Action, self._on_action)
        self.log.info("driver '%s'", self.driver.name)

    def _on_action(self, action: Action) -> None:
        scene = self.scenes.wait_for(action.episode_id, action.scene_sequence, timeout=2.0)
        final = self.skill.execute(action, scene, self.bus.publish)
        self.log.info(
            "%s %s -> %s: %s%s",
            action.decision_id,
            action.object_id,
            action.goal_id,
            final.state,
            f" ({final.reason}: {final.detail})" if final.reason else "",
        )

    def teardown(self) -> None:
        self.driver.close()
