"""Answers ``ExplainRequest`` queries from the planner's recent decisions (no bus in here)."""

from __future__ import annotations

import sys
import threading
from typing import TYPE_CHECKING

from manigraph_planner.decisions import DecisionHistory
from manigraph_planner.explain.config import ExplainerConfig
from manigraph_planner.policies.base import Policy
from manigraph_shared.errors import ConfigError, ManigraphError, PolicyError
from manigraph_shared.messages import (
    EXPLAINER_WARMING_UP,
    Action,
    ExplainRequest,
    Explanation,
)

if TYPE_CHECKING:
    from manigraph_planner.explain.scene_explainer import SceneExplainer

__all__ = ["ExplainHandler"]


class ExplainHandler:
    """Explains the latest decision, one by id, or a scene sent in the request.

    Every failure raises a :class:`~manigraph_shared.errors.ManigraphError` naming the field,
    which the bus turns into an error reply: a bad query is answered, never left hanging.

    Args:
        policy: the served policy; anything but a GNN policy makes every request an error.
        history: the planner's recent decisions and their scenes.
        config: the mask optimisation's settings.

    The explainer itself (a frozen copy of the network that scales messages by edge masks
    as dense algebra, :mod:`~manigraph_planner.explain.masked_forward`: no PyG import) is
    built, and warmed by one small explanation, by :meth:`prepare`, which the planner runs
    beside its first decisions (tens of milliseconds), or on first use. A request that comes
    while :meth:`prepare` is at it is refused ``explainer_warming_up`` at once (the client
    asks again), rather than held until the build is done.
    """

    def __init__(
        self, policy: Policy, history: DecisionHistory, config: ExplainerConfig | None = None
    ) -> None:
        self.history = history
        self.policy = policy
        self.config = config
        self.explainer: SceneExplainer | None = None
        self._building = threading.Lock()
        self.problem = ""
        # A GNN policy's class is loaded (and torch with it) iff a GNN policy was loaded:
        # any other policy is refused here without importing the explainer, or torch.
        gnn = sys.modules.get("manigraph_planner.policies.gnn")
        if gnn is None or not isinstance(policy, gnn.GNNPolicy):
            self.problem = (
                f"policy: '{policy.name}' is not a GNN policy; only GNN policies can be "
                "explained (start the planner with --policy CHECKPOINT.pt)"
            )
            return

    @property
    def available(self) -> bool:
        """The policy can be explained (a GNN policy)."""
        return not self.problem

    def prepare(self) -> None:
        """Build and warm the explainer now, if the policy can be explained (safe from any
        thread)."""
        if self.available:
            self._explainer(wait=True)

    def __call__(self, request: ExplainRequest) -> Explanation:
        if self.problem:
            raise PolicyError(self.problem)
        # Refused before the explainer is built: a planner just started (building it takes
        # seconds of PyG imports, far more on a loaded machine) refuses an oversized scene
        # at once rather than after that build.
        limits = self.config or ExplainerConfig()
        if request.scene is not None:
            limits.check_size(request.scene)
            return self._explainer(wait=False).explain_scene(
                request.scene, request.seed, wait=False
            )
        if request.wants_latest:
            found = self.history.latest()
            if found is None:
                raise ManigraphError("decision_id: the planner has made no decision yet")
        else:
            assert request.decision_id is not None
            found = self.history.get(request.decision_id)
            if found is None:
                kept = self.history.ids()
                known = f"{kept[0]} .. {kept[-1]}" if kept else "none made yet"
                raise ConfigError(  # a refusal: asking again fails again
                    "decision_id",
                    f"'{request.decision_id}' is not one of the planner's last "
                    f"{self.history.capacity} decisions ({known})",
                )
        scene, action = found
        limits.check_size(scene)
        return self._explainer(wait=False).explain(
            scene, action.object_id, action.goal_id, action.decision_id, request.seed, wait=False
        )

    def explain_action(self, action: Action) -> Explanation | None:
        """The explanation of a decision just made (None if it is no longer kept)."""
        found = self.history.get(action.decision_id)
        if found is None:
            return None
        scene, _ = found
        return self._explainer(wait=True).explain(
            scene, action.object_id, action.goal_id, action.decision_id
        )

    def _explainer(self, wait: bool) -> SceneExplainer:
        """The explainer, built (and warmed) here if nobody has yet; with ``wait`` False,
        refused ``explainer_warming_up`` while another thread is building it."""
        if self.problem:
            raise PolicyError(self.problem)
        if self.explainer is not None:
            return self.explainer
        if not self._building.acquire(blocking=wait):
            raise PolicyError(
                f"{EXPLAINER_WARMING_UP}: the explainer is being built; ask again in a moment"
            )
        try:
            if self.explainer is None:
                from manigraph_planner.explain.scene_explainer import SceneExplainer

                explainer = SceneExplainer(self.policy, self.config)
                explainer.warm_up()
                self.explainer = explainer
            return self.explainer
        finally:
            self._building.release()
