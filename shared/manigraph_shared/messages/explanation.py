"""Why the planner decided: the explainer's query and its answer (paper, "Interpreting the
learned GNN policy")."""

from __future__ import annotations

from typing import Annotated, ClassVar

from msgspec import Meta

from manigraph_shared.messages.base import Delivery, Identifier, Message, Stamp, Struct, Vector3
from manigraph_shared.messages.scene import MAX_ENTITIES, Scene

#: ``decision_id`` of a request that asks for the newest decision.
LATEST = "latest"
#: Start of the planner's refusal while its explainer is at work (one explanation at a time):
#: the one refusal a client may ask again after.
EXPLAINER_BUSY = "explainer_busy"
#: Start of the planner's refusal while its explainer is being built (right after start):
#: a client may ask again after it too.
EXPLAINER_WARMING_UP = "explainer_warming_up"
MAX_EXPLAINED_EDGES = 64
IDENTIFIER_PATTERN = r"^[A-Za-z0-9_.:\-]{1,64}$"


class ExplainRequest(Message, frozen=True, kw_only=True):
    """Ask the planner why it chose an object and a goal (query payload)."""

    key: ClassVar[str] = "manigraph/planner/explain"
    delivery: ClassVar[Delivery] = Delivery.QUERY
    publisher: ClassVar[str] = "explain client -> planner"

    decision_id: Annotated[
        Annotated[str, Meta(pattern=IDENTIFIER_PATTERN)] | None,
        Meta(description="decision to explain; null or `latest`: the newest one"),
    ] = None
    scene: Annotated[
        Scene | None,
        Meta(description="explain the decision the policy would take on this scene instead"),
    ] = None
    seed: Annotated[int, Meta(ge=0, le=2**32 - 1, description="seed of the mask optimisation")] = 0

    def _check(self) -> None:
        if self.scene is not None and self.decision_id not in (None, LATEST):
            raise ValueError("decision_id: give a decision id or a scene, not both")

    @property
    def wants_latest(self) -> bool:
        return self.scene is None and self.decision_id in (None, LATEST)


class ExplainedEdge(Struct, frozen=True, kw_only=True):
    """One edge of the explanation subgraph, by the ids of its nodes in the ``Scene``."""

    src: Identifier
    dst: Identifier
    weight: Annotated[float, Meta(ge=0.0, le=1.0, description="edge mask value, 1 = essential")]


class ExplainedNode(Struct, frozen=True, kw_only=True):
    """One node of the explained graph, where it was (for drawing the explanation)."""

    id: Identifier
    category: Annotated[
        str, Meta(max_length=16, description="block, cover, block-goal or cover-goal")
    ]
    position: Annotated[Vector3, Meta(description="metres, in the scene frame")]


class Explanation(Message, frozen=True, kw_only=True):
    """The edges and features that made the policy choose its object and goal."""

    key: ClassVar[str] = "manigraph/planner/explanation"
    delivery: ClassVar[Delivery] = Delivery.RELIABLE
    publisher: ClassVar[str] = "planner"

    decision_id: Annotated[
        Annotated[str, Meta(pattern=IDENTIFIER_PATTERN)] | None,
        Meta(description="the decision explained; null for a scene sent in the query"),
    ] = None
    episode_id: Identifier
    scene_sequence: Annotated[int, Meta(ge=0, description="sequence of the Scene explained")]
    policy: Annotated[str, Meta(max_length=128, description="name of the policy explained")]
    object: Annotated[Identifier, Meta(description="the object the policy chose")]
    goal: Annotated[Identifier, Meta(description="the goal the policy chose")]
    edges: Annotated[
        list[ExplainedEdge],
        Meta(
            max_length=MAX_EXPLAINED_EDGES, description="kept edges (at most c_E), strongest first"
        ),
    ]
    features: Annotated[
        dict[str, float],
        Meta(description="feature name -> importance in [0, 1], most important first"),
    ]
    nodes: Annotated[
        list[ExplainedNode],
        Meta(max_length=2 * MAX_ENTITIES, description="every node of the graph (none are removed)"),
    ]
    sentence: Annotated[str, Meta(max_length=1024, description="the explanation in words")]
    fidelity: Annotated[
        float,
        Meta(ge=0.0, le=1.0, description="p(object) p(goal) on the kept edges and features alone"),
    ]
    seed: Annotated[int, Meta(ge=0, description="seed of the mask optimisation")]
    stamp: Stamp

    def _check(self) -> None:
        for name, value in self.features.items():
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"features: importance of '{name}' must be in [0, 1]")
