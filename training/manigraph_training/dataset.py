"""Training samples from MCAP logs: each recorded Action with the Scene it was decided on.

Any log with ``manigraph/world/scene`` and ``manigraph/planner/action`` channels is training
data: ``manigraph demos`` output, the demonstration page's (``manigraph demo-ui``), or a run
recorded with ``manigraph up --record``; so is a LeRobot dataset that ``manigraph export``
wrote (``training.sources`` says which reader takes a path). An action is paired with the
scene whose ``episode_id`` and ``sequence`` it names (``scene_sequence``). Decisions on a
scene of a family with heads of its own (``family.family_of``) are
its trainer's and are skipped here; :func:`count_heads` says which kind a log holds.

What a node's features are is learned from the paired scenes too
(:meth:`~manigraph_planner.gnn.task_features.TaskFeatures.learn`): the paper's five columns
when no object carries an attribute and no goal lists what it accepts (every shipped recipe),
else those five and the task's columns (sizes, one-hot attributes, accepts).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import torch
from torch import Tensor

from manigraph_planner.family import family_of
from manigraph_planner.gnn.features import FEATURE_SPEC, FeatureSpec, GraphState, scene_to_graph
from manigraph_planner.gnn.models.config import HEADS
from manigraph_planner.gnn.task_features import TaskFeatures
from manigraph_shared.errors import LogError
from manigraph_shared.messages import Action, Scene
from manigraph_training.sources import read_source


@dataclass(frozen=True)
class Sample:
    """One expert decision on one graph: node features and the chosen object/goal nodes."""

    x: Tensor  # (N, F): the demonstrations' feature spec
    is_object: Tensor  # (N,) bool
    object_index: int  # node index of the expert's object
    goal_index: int  # node index of the expert's goal

    def with_x(self, x: Tensor) -> Sample:
        return Sample(x, self.is_object, self.object_index, self.goal_index)


@dataclass(frozen=True)
class Demonstrations:
    samples: list[Sample]
    data_hash: str
    episodes: int
    skipped: int
    #: What the columns of every sample's ``x`` mean, learned from the scenes.
    feature_spec: FeatureSpec = FEATURE_SPEC
    #: The task family every sample's scene belongs to (``family.family_of``); None for
    #: samples of several families.
    family: str | None = None


def read_decisions(paths: Iterable[Path]) -> tuple[dict[tuple[str, int], Scene], list[Action]]:
    """Every scene (by episode and sequence) and every action of the logs ``paths``."""
    scenes: dict[tuple[str, int], Scene] = {}
    actions: list[Action] = []
    for path in sorted(paths):
        for message in read_source(path):  # an MCAP log, a LeRobot dataset (training.sources)
            if isinstance(message, Scene):
                scenes[(message.episode_id, message.sequence)] = message
            elif isinstance(message, Action):
                actions.append(message)
    return scenes, actions


#: The heads this module's samples train: the paper's object and goal (``ModelConfig.heads``).
OBJECT_GOAL_HEADS = "object-goal"


def heads_of(scene: Scene) -> str:
    """The heads a decision on ``scene`` trains: its task family's (``families.family_of``)."""
    return family_of(scene).heads


def count_heads(paths: Iterable[Path]) -> dict[str, int]:
    """How many decisions of the logs train each kind of policy (those paired with a scene),
    by heads (every registered heads, the paper's first)."""
    scenes, actions = read_decisions(paths)
    counts = dict.fromkeys(HEADS, 0)
    for action in actions:
        scene = scenes.get((action.episode_id, action.scene_sequence))
        if scene is not None:
            counts[heads_of(scene)] += 1
    return counts


def load_demonstrations(paths: Iterable[Path]) -> Demonstrations:
    """Every decision paired with its scene, as samples of the feature spec the scenes need.

    Raises:
        LogError: no decision pairs with a scene, or an attribute is text in one scene and a
            number in another (naming it).
    """
    scenes, actions = read_decisions(paths)
    paired = [scenes.get((action.episode_id, action.scene_sequence)) for action in actions]
    try:
        task = TaskFeatures.learn(s for s in paired if s is not None and _trains_here(s))
    except ValueError as exc:
        raise LogError(f"demonstrations: {exc}") from None
    spec = FeatureSpec.for_task(task)
    digest = hashlib.sha256()
    samples: list[Sample] = []
    skipped = 0
    episodes = set()
    families = set()
    for action, scene in zip(actions, paired, strict=True):
        trains = scene is not None and _trains_here(scene)
        sample = _sample(scene, action, spec) if scene is not None and trains else None
        if sample is None:
            skipped += 1
            continue
        samples.append(sample)
        episodes.add(action.episode_id)
        families.add(family_of(scene).name if scene else "")
        digest.update(scene.encode() if scene else b"")
        digest.update(f"{action.object_id}->{action.goal_id}".encode())
    if not samples:
        raise LogError("demonstrations: no action could be paired with the scene it was decided on")
    family = families.pop() if len(families) == 1 else None
    return Demonstrations(samples, digest.hexdigest()[:16], len(episodes), skipped, spec, family)


def _trains_here(scene: Scene) -> bool:
    """Whether a decision on ``scene`` trains the object-goal heads (another family's heads
    are trained by its own ``PlannerFamily.trainer``)."""
    return heads_of(scene) == OBJECT_GOAL_HEADS


def _sample(scene: Scene, action: Action, spec: FeatureSpec = FEATURE_SPEC) -> Sample | None:
    graph: GraphState = scene_to_graph(scene, spec)
    try:
        object_index = graph.object_ids.index(action.object_id)
        goal_index = graph.num_objects + graph.goal_ids.index(action.goal_id)
    except ValueError:
        return None  # the decision named a node that was not visible
    return Sample(graph.x.clone(), graph.is_object.clone(), object_index, goal_index)


def stack_targets(samples: list[Sample]) -> tuple[Tensor, Tensor]:
    return (
        torch.tensor([s.object_index for s in samples]),
        torch.tensor([s.goal_index for s in samples]),
    )
