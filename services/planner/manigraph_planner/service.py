"""The planner service: serves one policy over the bus (and, for GNN policies, explains it)."""

from __future__ import annotations

from manigraph_planner.decisions import DecisionMaker
from manigraph_planner.explain.handler import ExplainHandler
from manigraph_planner.policies.base import Policy
from manigraph_shared.bus import Bus
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import Action, EpisodeEvent, ExplainRequest, Scene, SkillStatus
from manigraph_shared.service import Service


class PlannerService(Service):
    """Decides on scenes; answers ``manigraph/planner/explain`` queries.

    Explain queries run on a Zenoh thread against the explainer's own copy of the network,
    so they never delay or disturb a decision.

    Args:
        bus: the process's bus.
        policy: the policy served.
        explain_decisions: also publish an ``Explanation`` after every decision (GNN only),
            so explanations land in the MCAP log beside the decisions.
    """

    name = "planner"

    def __init__(self, bus: Bus, policy: Policy, explain_decisions: bool = False) -> None:
        super().__init__(bus)
        self.decisions = DecisionMaker(policy)
        self.explain = ExplainHandler(policy, self.decisions.history)
        self.explain_decisions = explain_decisions

    def setup(self) -> None:
        if self.explain_decisions and not self.explain.available:
            raise PolicyError(f"explain_decisions: {self.explain.problem}")
        self.on(EpisodeEvent, self.decisions.on_episode)
        self.on(SkillStatus, lambda status: self._act(self.decisions.on_status(status)))
        self.on(Scene, lambda scene: self._act(self.decisions.on_scene(scene)))
        self.bus.serve(ExplainRequest, self.explain)
        self.log.info(
            "serving policy '%s'%s",
            self.decisions.policy.name,
            " (explaining every decision)" if self.explain_decisions else "",
        )

    def _act(self, action: Action | None) -> None:
        if action is None:
            return
        self.log.info(
            "%s: %s -> %s (scene %d)",
            action.decision_id,
            action.object_id,
            action.goal_id,
            action.scene_sequence,
        )
        self.bus.publish(action)
        if self.explain_decisions:  # after the action: the skill starts while we explain
            explanation = self.explain.explain_action(action)
            if explanation is not None:
                self.bus.publish(explanation)
