"""Training samples from MCAP logs: each recorded Action with the Scene it was decided on.

Any log with ``manigraph/world/scene`` and ``manigraph/planner/action`` channels is training
data: ``manigraph demos`` output, or a run recorded with ``manigraph up --record``. An action
is paired with the scene whose ``episode_id`` and ``sequence`` it names (``scene_sequence``).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import torch
from torch import Tensor

from manigraph_planner.gnn.features import GraphState, scene_to_graph
from manigraph_shared.errors import LogError
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene


@dataclass(frozen=True)
class Sample:
    """One expert decision on one graph: node features and the chosen object/goal nodes."""

    x: Tensor  # (N, 5)
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


def recorded_decisions(paths: Iterable[Path]) -> list[tuple[Scene | None, Action]]:
    """Every Action in the logs at ``paths`` (in file-name order, then log order) with the
    Scene it was decided on, or None if no log holds that scene.

    Raises:
        LogError: a path is not a file.
    """
    scenes: dict[tuple[str, int], Scene] = {}
    actions: list[Action] = []
    for path in sorted(paths):
        if not path.is_file():
            raise LogError(f"demonstrations: no such file: {path}")
        for item in read_log(path, [Scene.key, Action.key]):
            message = item.decode()
            if isinstance(message, Scene):
                scenes[(message.episode_id, message.sequence)] = message
            elif isinstance(message, Action):
                actions.append(message)
    return [(scenes.get((a.episode_id, a.scene_sequence)), a) for a in actions]


def load_demonstrations(paths: Iterable[Path]) -> Demonstrations:
    digest = hashlib.sha256()
    samples: list[Sample] = []
    skipped = 0
    episodes = set()
    for scene, action in recorded_decisions(paths):
        sample = _sample(scene, action) if scene is not None else None
        if sample is None:
            skipped += 1
            continue
        samples.append(sample)
        episodes.add(action.episode_id)
        digest.update(scene.encode() if scene else b"")
        digest.update(f"{action.object_id}->{action.goal_id}".encode())
    if not samples:
        raise LogError("demonstrations: no action could be paired with the scene it was decided on")
    return Demonstrations(samples, digest.hexdigest()[:16], len(episodes), skipped)


def _sample(scene: Scene, action: Action) -> Sample | None:
    graph: GraphState = scene_to_graph(scene)
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
