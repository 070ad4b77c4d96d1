"""The planner service: serves one policy over the bus."""

from __future__ import annotations

from manigraph_planner.decisions import DecisionMaker
from manigraph_planner.policies.base import Policy
from manigraph_shared.bus import Bus
from manigraph_shared.messages import Action, EpisodeEvent, Scene, SkillStatus
from manigraph_shared.service import Service


class PlannerService(Service):
    name = "planner"

    def __init__(self, bus: Bus, policy: Policy) -> None:
        super().__init__(bus)
        self.decisions = DecisionMaker(policy)

    def setup(self) -> None:
        self.on(EpisodeEvent, self.decisions.on_episode)
        self.on(SkillStatus, lambda status: self._act(self.decisions.on_status(status)))
        self.on(Scene, lambda scene: self._act(self.decisions.on_scene(scene)))
        self.log.info("serving policy '%s'", self.decisions.policy.name)

    def _act(self, action: Action | None) -> None:
        if action is not None:
            self.log.info(
                "%s: %s -> %s (scene %d)",
                action.decision_id,
                action.object_id,
                action.goal_id,
                action.scene_sequence,
            )
            self.bus.publish(action)
