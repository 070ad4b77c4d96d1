r"""The graph state of the paper: a scene as a dense graph of object and goal nodes.

Given :math:`K` visible objects and :math:`L` visible goals, the graph
:math:`G = (V, E)` has the :math:`K + L` nodes
:math:`V = \{v^o_k\}_{k=1}^K \cup \{v^g_l\}_{l=1}^L` (objects first, then goals) and is
fully connected: :math:`E = \{(j, i) : i \neq j\}`, directed both ways, so
:math:`|E| = N (N - 1)` with :math:`N = K + L`. There are no self loops; every layer
carries a node's own state through its root weight (:math:`\theta_1 h_i`).

Each node has the 5-dimensional feature

.. math::
    \phi(v) = [\,c,\; x,\; y,\; z,\; f\,]

* :math:`c` — category code: cover 0, block 1, goal for a block 2, goal for a cover 3;
* :math:`x, y, z` — position in the scene frame (the robot frame), metres, unscaled;
* :math:`f` — 1 if a goal is filled or an object rests in a goal of its category, else 0.

Only ``visible`` objects and goals become nodes: the policy must not see inside a closed box.

A policy trained on task-file demonstrations whose objects carry ``attributes`` or whose goals
list what they ``accepts`` has wider nodes: these five columns, then the columns of the
:class:`~.task_features.TaskFeatures` learned from the demonstrations' scenes and stamped in
its checkpoint (``FeatureSpec.task``; :func:`scene_to_graph` takes the spec).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import torch
from torch import Tensor

from manigraph_planner.family import family_of
from manigraph_planner.gnn.goal_support import ready_goals
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneGoal, SceneObject

__all__ = [
    "FEATURE_SPEC",
    "FeatureSpec",
    "GraphState",
    "fully_connected_edge_index",
    "graph_from_arrays",
    "scene_to_graph",
]


@dataclass(frozen=True)
class FeatureSpec:
    """What a node feature vector means; stamped into checkpoints and compared on load.

    Args:
        names: the name of each feature column, in order.
        category_codes: ``(category, code)`` pairs for the ``category`` column.
        version: bump when the meaning changes without the names or codes changing
            (frame, units, which nodes or edges exist).
        task: the columns a task's attributes and accepts add after the paper's five
            (:meth:`for_task`); None, the paper's spec, which every shipped checkpoint has.
    """

    names: tuple[str, ...] = ("category", "x", "y", "z", "filled")
    category_codes: tuple[tuple[str, int], ...] = (
        ("cover", 0),
        ("block", 1),
        ("block-goal", 2),
        ("cover-goal", 3),
    )
    version: str = "1"
    task: TaskFeatures | None = None

    @classmethod
    def for_task(cls, task: TaskFeatures | None) -> FeatureSpec:
        """The paper's five columns followed by ``task``'s (the paper's spec for None)."""
        if task is None:
            return FEATURE_SPEC
        return cls(names=(*FEATURE_SPEC.names, *task.names), task=task)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> FeatureSpec:
        """The spec :meth:`to_dict` wrote; ``ValueError`` naming the field."""
        task = TaskFeatures.from_dict(values["task"]) if "task" in values else None
        spec = cls.for_task(task)
        if tuple(values.get("names", ())) != spec.names:
            raise ValueError(f"names: do not match the task's columns {list(spec.names)}")
        return spec

    def __post_init__(self) -> None:
        if not self.names or len(set(self.names)) != len(self.names):
            raise ValueError(f"names: must be non-empty and unique, got {self.names}")
        categories = [name for name, _ in self.category_codes]
        codes = [code for _, code in self.category_codes]
        if len(set(categories)) != len(categories) or len(set(codes)) != len(codes):
            raise ValueError(
                f"category_codes: categories and codes must be unique, got {self.category_codes}"
            )
        if not self.version:
            raise ValueError("version: must be a non-empty string")
        if self.task is not None and self.names[5:] != self.task.names:
            raise ValueError("names: a task spec's names are the five of the paper, then its own")

    @property
    def num_features(self) -> int:
        return len(self.names)

    def code(self, category: str) -> int:
        """The code of ``category`` (``"cover"``, ``"block"``, ``"block-goal"``, ...)."""
        return dict(self.category_codes)[category]

    def to_dict(self) -> dict[str, Any]:
        """Plain types only, so ``torch.load(weights_only=True)`` can read it back."""
        values: dict[str, Any] = {
            "names": list(self.names),
            "category_codes": dict(self.category_codes),
            "version": self.version,
        }
        if self.task is not None:  # the paper's spec stays what every checkpoint holds
            values["task"] = self.task.to_dict()
        return values


#: The feature spec this code builds; checkpoints made with another one are refused.
FEATURE_SPEC = FeatureSpec()

_OBJECT_CODE = {
    ObjectCategory.COVER: FEATURE_SPEC.code("cover"),
    ObjectCategory.BLOCK: FEATURE_SPEC.code("block"),
}
_GOAL_CODE = {
    GoalCategory.BLOCK: FEATURE_SPEC.code("block-goal"),
    GoalCategory.COVER: FEATURE_SPEC.code("cover-goal"),
}
_ALL_CODES = frozenset(code for _, code in FEATURE_SPEC.category_codes)


@dataclass
class GraphState:
    """One scene as a graph, ready for a :class:`~manigraph_planner.gnn.models.PolicyNet`.

    Nodes are ordered objects first, then goals; ``object_ids[k]`` is node ``k`` and
    ``goal_ids[l]`` is node ``len(object_ids) + l``.

    Shapes:
        - **x:** :math:`(N, F)` float32, :math:`F` the spec's columns (5: the paper's)
        - **edge_index:** :math:`(2, N (N - 1))` int64, row 0 source, row 1 target.
          Shared with a per-:math:`N` cache: never modify it in place.
        - **is_object:** :math:`(N,)` bool
    """

    x: Tensor
    edge_index: Tensor
    object_ids: list[str]
    goal_ids: list[str]
    is_object: Tensor = field(repr=False)

    @property
    def num_nodes(self) -> int:
        return int(self.x.shape[0])

    @property
    def num_objects(self) -> int:
        return len(self.object_ids)

    def to_data(self, **extra: Any) -> Any:
        """A ``torch_geometric.data.Data`` for ``Batch.from_data_list``; ``extra`` attaches
        targets. Attributes whose name contains ``index`` (``object_index``) are offset by
        the node count when batched, so node-index targets stay correct."""
        from torch_geometric.data import Data

        return Data(x=self.x, edge_index=self.edge_index, is_object=self.is_object, **extra)


@lru_cache(maxsize=512)
def fully_connected_edge_index(num_nodes: int) -> Tensor:
    """Every ordered pair ``(j, i)`` with ``i != j``, sorted by source then target.

    Cached per ``num_nodes``; the returned tensor is shared, so never modify it in place.

    Shapes:
        - **output:** :math:`(2, N (N - 1))` int64
    """
    if num_nodes < 0:
        raise ValueError(f"num_nodes: must be >= 0, got {num_nodes}")
    nodes = torch.arange(num_nodes)
    source = nodes.repeat_interleave(num_nodes)
    target = nodes.repeat(num_nodes)
    keep = source != target
    return torch.stack([source[keep], target[keep]])


def scene_to_graph(scene: Scene, spec: FeatureSpec | None = None) -> GraphState:
    """The paper's graph state of ``scene``: visible objects, then visible goals; with a
    task ``spec`` (:meth:`FeatureSpec.for_task`), each node's task columns after the five.

    Raises:
        PolicyError: an entity of another family (a dish), or a value outside the spec's
            vocabulary, naming it.
    """
    task = spec.task if spec is not None else None
    ready = ready_goals(scene) if task is not None and task.goal_support else frozenset()
    rows: list[list[float]] = []
    object_ids: list[str] = []
    goal_ids: list[str] = []
    entities: list[SceneObject | SceneGoal] = [*scene.objects, *scene.goals]
    for entity in entities:
        if entity.category not in _OBJECT_CODE and entity.category not in _GOAL_CODE:
            raise PolicyError(
                f"scene: '{entity.id}' is a {entity.category}; this policy knows blocks and "
                f"covers{_needs_heads(scene)}"
            )
    for obj in scene.objects:
        if obj.visible:
            p = obj.position
            rows.append([_OBJECT_CODE[obj.category], p.x, p.y, p.z, float(obj.filled)])
            if task is not None:
                rows[-1].extend(task.object_row(obj))
            object_ids.append(obj.id)
    for goal in scene.goals:
        if goal.visible:
            p = goal.position
            rows.append([_GOAL_CODE[goal.category], p.x, p.y, p.z, float(goal.filled)])
            if task is not None:
                rows[-1].extend(task.goal_row(goal, ready=goal.id in ready))
            goal_ids.append(goal.id)
    num_nodes = len(rows)
    width = (spec or FEATURE_SPEC).num_features
    x = torch.tensor(rows, dtype=torch.float32) if rows else torch.zeros(0, width)
    is_object = torch.zeros(num_nodes, dtype=torch.bool)
    is_object[: len(object_ids)] = True
    return GraphState(x, fully_connected_edge_index(num_nodes), object_ids, goal_ids, is_object)


def graph_from_arrays(
    category: Sequence[int] | Tensor,
    position: Sequence[Sequence[float]] | Tensor,
    filled: Sequence[float] | Tensor,
    *,
    object_ids: Sequence[str] | None = None,
    goal_ids: Sequence[str] | None = None,
) -> GraphState:
    """A graph state from raw per-node arrays (training-time augmentation, synthetic data).

    Nodes must already be ordered objects first (codes 0, 1), then goals (codes 2, 3), as
    :func:`scene_to_graph` orders them. Ids default to ``object-<k>`` / ``goal-<l>``.
    Accepts anything ``torch.as_tensor`` accepts, including numpy arrays.

    Shapes:
        - **category:** :math:`(N,)` integer codes
        - **position:** :math:`(N, 3)` metres
        - **filled:** :math:`(N,)` 0 or 1
    """
    codes = torch.as_tensor(category).reshape(-1)
    pos = torch.as_tensor(position, dtype=torch.float32)
    fill = torch.as_tensor(filled, dtype=torch.float32).reshape(-1)
    num_nodes = int(codes.shape[0])
    if codes.is_floating_point() and not torch.equal(codes, codes.round()):
        raise ValueError("category: codes must be whole numbers")
    codes = codes.to(torch.int64)
    if not set(codes.tolist()) <= _ALL_CODES:
        raise ValueError(f"category: codes must be in {sorted(_ALL_CODES)}, got {codes.tolist()}")
    if pos.shape != (num_nodes, 3):
        raise ValueError(f"position: expected shape ({num_nodes}, 3), got {tuple(pos.shape)}")
    if not bool(torch.isfinite(pos).all()):
        raise ValueError("position: every coordinate must be finite")
    if fill.shape != (num_nodes,) or not bool(((fill == 0) | (fill == 1)).all()):
        raise ValueError(f"filled: expected {num_nodes} values, each 0 or 1")
    is_object = (codes == 0) | (codes == 1)
    num_objects = int(is_object.sum())
    if not bool(is_object[:num_objects].all()):
        raise ValueError("category: object nodes (codes 0, 1) must come before goal nodes")
    object_ids = _ids(object_ids, "object", num_objects, "object_ids")
    goal_ids = _ids(goal_ids, "goal", num_nodes - num_objects, "goal_ids")
    x = torch.cat([codes.to(torch.float32).unsqueeze(1), pos, fill.unsqueeze(1)], dim=1)
    return GraphState(x, fully_connected_edge_index(num_nodes), object_ids, goal_ids, is_object)


def _ids(given: Sequence[str] | None, prefix: str, count: int, name: str) -> list[str]:
    if given is None:
        return [f"{prefix}-{k}" for k in range(count)]
    if len(given) != count:
        raise ValueError(f"{name}: expected {count} ids, got {len(given)}")
    return list(given)


def _needs_heads(scene: Scene) -> str:
    """What a scene of another family needs, by the registry: `` (a <family> scene needs a
    checkpoint with <heads> heads)``, or nothing for a scene no family claims."""
    family = family_of(scene)
    if family.fallback:
        return ""
    return f" (a {family.name} scene needs a checkpoint with {family.heads} heads)"
