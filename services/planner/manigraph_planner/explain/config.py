"""Settings of the modified GNNExplainer, validated once."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from manigraph_shared.errors import ConfigError, PolicyError
from manigraph_shared.messages import Scene

__all__ = ["ExplainerConfig", "Objective"]


class Objective(StrEnum):
    """What the masks are fitted to keep (see :mod:`manigraph_planner.explain.masks`)."""

    #: the chosen pair's log-likelihood under the whole object and goal distributions, every
    #: edge a candidate (the paper's Eq. red_mi as cross-entropy)
    DISTRIBUTION = "distribution"
    #: the chosen object's and goal's logit margins over their runners-up, kept on the
    #: explanation and lost on its complement; only edges incident to the chosen object or
    #: goal are candidates
    PAIR = "pair"
    #: the ``pair`` objective with every edge in the masked graph (budgeted), so what the
    #: choice needs beyond the chosen nodes' own edges stays as context; only edges incident
    #: to the chosen object or goal are shown
    PAIR_CONTEXT = "pair-context"


@dataclass(frozen=True)
class ExplainerConfig:
    r"""Hyper-parameters of :class:`~manigraph_planner.explain.masks.MaskExplainer`.

    Args:
        steps: Adam steps of the mask optimisation. The default keeps a K = 9 stacking scene
            (18 nodes, 306 edges) well under 250 ms on one CPU thread.
        learning_rate: Adam step size on the mask logits (0.1 before the ``pair-context``
            objective; at 0.1 it left gated's soft explanation without the choice in a quarter
            of 3-stack decisions, at 0.2 in none of 25, at the same 40 steps).
        edge_budget: :math:`c_E`, the most edges the explanation keeps (:math:`|E_S| \le c_E`).
        feature_budget: :math:`c_F`, the most features it keeps (:math:`\sum_j F_j \le c_F`).
        budget_weight: :math:`\lambda`, weight of the penalty on mask mass over a budget.
        entropy_weight: :math:`\beta`, weight of the penalty on undecided (near 0.5) mask values.
        initial_edge_logit: mean of the initial edge mask logits; 3 starts every edge at
            :math:`\sigma(3) \approx 0.95`, i.e. from the policy's own graph, so the budget
            penalty removes what the choice does not need.
        seed: seed of the mask initialisation; the same seed gives the same explanation.
        objective: :class:`Objective`; ``pair-context`` (the default) measured more faithful than
            ``distribution`` (docs/explainer-faithfulness.md).
        complement_weight: :math:`\gamma`, weight of the ``pair`` objective's term that the
            choice be lost without the explanation (fidelity+).
        max_nodes: the largest scene explained (visible objects + goals); a bigger one is
            refused (``scene_too_large``). The cost grows with the square of the nodes: 80
            nodes (K = 40) take ~0.3 s, 512 took 22 s and gigabytes before this bound.
        deadline_seconds: an explanation still optimising after this long is abandoned
            (``explain_deadline``).

    Raises:
        ConfigError: naming the offending field.
    """

    steps: int = 40
    learning_rate: float = 0.2
    edge_budget: int = 3
    feature_budget: int = 2
    budget_weight: float = 0.2
    entropy_weight: float = 0.1
    initial_edge_logit: float = 3.0
    seed: int = 0
    objective: Objective = Objective.PAIR_CONTEXT
    complement_weight: float = 1.0
    max_nodes: int = 128
    deadline_seconds: float = 5.0

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "objective", Objective(self.objective))
        except ValueError:
            allowed = ", ".join(o.value for o in Objective)
            raise ConfigError(
                "objective", f"must be one of {allowed}, got {self.objective!r}"
            ) from None
        for name, low in (("steps", 1), ("edge_budget", 1), ("feature_budget", 1), ("seed", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ConfigError(name, f"must be an integer >= {low}, got {value!r}")
        if self.steps > 10_000:
            raise ConfigError("steps", f"must be <= 10000, got {self.steps}")
        if self.edge_budget > 64:
            raise ConfigError("edge_budget", f"must be <= 64, got {self.edge_budget}")
        for name in ("learning_rate", "budget_weight", "entropy_weight", "complement_weight"):
            value = getattr(self, name)
            if not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
                raise ConfigError(name, f"must be a finite number >= 0, got {value!r}")
        if not isinstance(self.initial_edge_logit, int | float) or not (
            -10.0 <= self.initial_edge_logit <= 10.0
        ):
            raise ConfigError(
                "initial_edge_logit", f"must be in [-10, 10], got {self.initial_edge_logit!r}"
            )
        if isinstance(self.max_nodes, bool) or not isinstance(self.max_nodes, int):
            raise ConfigError("max_nodes", f"must be an integer, got {self.max_nodes!r}")
        if not 2 <= self.max_nodes <= 512:
            raise ConfigError("max_nodes", f"must be in [2, 512], got {self.max_nodes}")
        if not isinstance(self.deadline_seconds, int | float) or not (
            0 < self.deadline_seconds <= 600
        ):
            raise ConfigError(
                "deadline_seconds", f"must be in (0, 600] seconds, got {self.deadline_seconds!r}"
            )
        if self.learning_rate == 0:
            raise ConfigError("learning_rate", "must be > 0")

    def check_size(self, scene: Scene) -> None:
        """Raises ``PolicyError`` (``scene_too_large``) for a scene over ``max_nodes``. Cheap
        and free of PyG: a query is refused so before the explainer is even built."""
        nodes = sum(o.visible for o in scene.objects) + sum(g.visible for g in scene.goals)
        if nodes > self.max_nodes:
            raise PolicyError(
                f"scene_too_large: {nodes} visible nodes, the explainer takes at most "
                f"{self.max_nodes}"
            )
