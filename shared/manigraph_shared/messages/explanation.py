"""Why the planner decided: the explainer's query and its answer (paper, "Interpreting the
learned GNN policy")."""

from __future__ import annotations

from typing import ClassVar, Self

from pydantic import Field, model_validator

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp, Struct, Vector3
from manigraph_shared.messages.scene import MAX_ENTITIES, Scene

#: ``decision_id`` of a request that asks for the newest decision.
LATEST = "latest"
MAX_EXPLAINED_EDGES = 64
IDENTIFIER_PATTERN = r"^[A-Za-z0-9_.:\-]{1,64}$"


class ExplainRequest(Message):
    """Ask the planner why it chose an object and a goal (query payload)."""

    key: ClassVar[str] = "manigraph/planner/explain"
    delivery: ClassVar[Delivery] = Delivery.QUERY
    publisher: ClassVar[str] = "explain client -> planner"

    decision_id: str | None = Field(
        None,
        pattern=IDENTIFIER_PATTERN,
        description="decision to explain; null or `latest`: the newest one",
    )
    scene: Scene | None = Field(
        None, description="explain the decision the policy would take on this scene instead"
    )
    seed: int = Field(0, ge=0, le=2**32 - 1, description="seed of the mask optimisation")

    @model_validator(mode="after")
    def _one_subject(self) -> Self:
        if self.scene is not None and self.decision_id not in (None, LATEST):
            raise ValueError("decision_id: give a decision id or a scene, not both")
        return self

    @property
    def wants_latest(self) -> bool:
        return self.scene is None and self.decision_id in (None, LATEST)


class ExplainedEdge(Struct):
    """One edge of the explanation subgraph, by the ids of its nodes in the ``Scene``."""

    src: Identifier
    dst: Identifier
    weight: float = Field(ge=0.0, le=1.0, description="edge mask value, 1 = essential")


class ExplainedNode(Struct):
    """One node of the explained graph, where it was (for drawing the explanation)."""

    id: Identifier
    category: str = Field(max_length=16, description="block, cover, block-goal or cover-goal")
    position: Vector3 = Field(description="metres, in the scene frame")


class Explanation(Message):
    """The edges and features that made the policy choose its object and goal."""

    key: ClassVar[str] = "manigraph/planner/explanation"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "planner"

    decision_id: str | None = Field(
        None,
        pattern=IDENTIFIER_PATTERN,
        description="the decision explained; null for a scene sent in the query",
    )
    episode_id: Identifier
    scene_sequence: int = Field(ge=0, description="sequence of the Scene explained")
    policy: str = Field(max_length=128, description="name of the policy explained")
    object: Identifier = Field(description="the object the policy chose")
    goal: Identifier = Field(description="the goal the policy chose")
    edges: list[ExplainedEdge] = Field(
        max_length=MAX_EXPLAINED_EDGES, description="kept edges (at most c_E), strongest first"
    )
    features: dict[str, float] = Field(
        description="feature name -> importance in [0, 1], most important first"
    )
    nodes: list[ExplainedNode] = Field(
        max_length=2 * MAX_ENTITIES, description="every node of the graph (none are removed)"
    )
    sentence: str = Field(max_length=1024, description="the explanation in words")
    fidelity: float = Field(
        ge=0.0, le=1.0, description="p(object) p(goal) on the kept edges and features alone"
    )
    seed: int = Field(ge=0, description="seed of the mask optimisation")
    stamp: Stamp

    @model_validator(mode="after")
    def _importances_in_range(self) -> Self:
        for name, value in self.features.items():
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"features: importance of '{name}' must be in [0, 1]")
        return self
