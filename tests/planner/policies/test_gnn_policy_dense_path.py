"""GNNPolicy runs the dense complete-graph path; its decisions are message passing's.

Untrained GCN policies are the exception that needs care: summing 79 neighbours over three
layers makes their K = 40 logits ~1e4 apart by ~1e-3, below float32 resolution, so message
passing's own choice there is decided by rounding. Those ties are checked in float64.
"""

from __future__ import annotations

import copy
import random
from collections.abc import Callable
from pathlib import Path

import pytest
import torch

from manigraph_planner.gnn.features import GraphState, scene_to_graph
from manigraph_planner.gnn.models import ARCHITECTURES, ModelConfig, PolicyNet
from manigraph_planner.gnn.models.build import with_message_passing
from manigraph_planner.policies.base import Decision
from manigraph_planner.policies.gnn import GNNPolicy, decision_from_logits
from manigraph_shared.messages import (
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)

ARCHS = sorted(ARCHITECTURES)
CHECKPOINTS = Path(__file__).resolve().parents[3] / "checkpoints"
SIZE = Vector3(x=0.04, y=0.04, z=0.04)
STACK_SIZES = (1, 2, 3, 9, 40)


def mixed_scene(num_objects: int, num_goals: int, seed: int) -> Scene:
    """Blocks and covers, goals of both categories, some filled, some hidden, anywhere."""
    rng = random.Random(seed)

    def position() -> Vector3:
        return Vector3(x=rng.uniform(0.2, 0.7), y=rng.uniform(-0.3, 0.3), z=rng.uniform(0, 0.3))

    objects = [
        SceneObject(
            id=f"o{i}",
            category=rng.choice([ObjectCategory.COVER, ObjectCategory.BLOCK]),  # the block tasks'
            position=position(),
            size=SIZE,
            filled=rng.random() < 0.3,
            visible=rng.random() < 0.9,
        )
        for i in range(num_objects)
    ]
    goals = [
        SceneGoal(
            id=f"g{i}",
            category=rng.choice([GoalCategory.BLOCK, GoalCategory.COVER]),
            position=position(),
            filled=rng.random() < 0.3,
            visible=rng.random() < 0.9,
        )
        for i in range(num_goals)
    ]
    return Scene(episode_id="test", stamp=1.0, sequence=seed, objects=objects, goals=goals)


def decide_by_message_passing(policy: GNNPolicy, scene: Scene) -> Decision | None:
    """What ``policy.decide`` computes, through PyG message passing on the edge index (a
    served policy holds only its layers' weights: the PyG network is rebuilt from them)."""
    graph = scene_to_graph(scene)
    if graph.num_objects in (0, graph.num_nodes):
        return None
    with torch.no_grad():
        net = with_message_passing(policy.net)
        return decision_from_logits(graph, net(graph.x, graph.edge_index))


def scenes(make_stack_scene: Callable[[int], Scene]) -> list[Scene]:
    stacks = [make_stack_scene(k) for k in STACK_SIZES]
    return stacks + [mixed_scene(k, k + seed % 3, seed) for seed, k in enumerate((2, 5, 12, 40))]


def pair_log_probability(graph: GraphState, node_logits: torch.Tensor, decision: Decision) -> float:
    k = graph.num_objects
    object_logp = node_logits[:k].log_softmax(0)[graph.object_ids.index(decision.object_id)]
    goal_logp = node_logits[k:].log_softmax(0)[graph.goal_ids.index(decision.goal_id)]
    return float(object_logp + goal_logp)


def assert_rounding_tie(policy: GNNPolicy, scene: Scene, first: Decision, second: Decision) -> None:
    """``first`` and ``second`` score the same under float64 logits, to float32 resolution."""
    graph = scene_to_graph(scene)
    net = copy.deepcopy(with_message_passing(policy.net)).double()
    with torch.no_grad():
        logits = net(graph.x.double(), graph.edge_index)
    gap = pair_log_probability(graph, logits, first) - pair_log_probability(graph, logits, second)
    assert abs(gap) <= 1e-5 * float(logits.abs().max()), f"{first} vs {second}: gap {gap}"


def assert_same_as_message_passing(
    policy: GNNPolicy, scene_list: list[Scene], *, allow_rounding_ties: bool
) -> None:
    """``decide`` picks message passing's pair; with ``allow_rounding_ties`` it may instead
    pick a pair that float32 rounding cannot tell apart from it (message passing's own pick
    is then just as much a coin flip)."""
    for scene in scene_list:
        dense, expected = policy.decide(scene), decide_by_message_passing(policy, scene)
        if dense != expected and allow_rounding_ties and dense and expected:
            assert_rounding_tie(policy, scene, dense, expected)
        else:
            assert dense == expected, f"scene {scene.sequence}"


@pytest.mark.parametrize("arch", ARCHS)
def test_random_weight_policies_decide_as_message_passing_does(
    arch: str, make_stack_scene: Callable[[int], Scene]
) -> None:
    scene_list = scenes(make_stack_scene)
    for seed in range(3):
        torch.manual_seed(seed)
        policy = GNNPolicy(PolicyNet(ModelConfig(arch)))
        assert_same_as_message_passing(policy, scene_list, allow_rounding_ties=True)


@pytest.mark.parametrize("arch", ARCHS)
def test_shipped_checkpoints_decide_as_message_passing_does(
    arch: str, make_stack_scene: Callable[[int], Scene]
) -> None:
    path = CHECKPOINTS / f"{arch}.pt"
    if not path.is_file():
        pytest.skip(f"no shipped checkpoint {path}")
    policy = GNNPolicy.from_checkpoint(path)
    assert not policy.net.message_passing  # served from its weights alone, as the planner does
    assert_same_as_message_passing(policy, scenes(make_stack_scene), allow_rounding_ties=False)


def test_decide_does_not_run_message_passing(make_stack_scene: Callable[[int], Scene]) -> None:
    """``decide`` never calls ``PolicyNet.forward`` (PyG message passing over the edges)."""
    policy = GNNPolicy(PolicyNet(ModelConfig("gat")))

    def refuse_message_passing(*args: object) -> None:
        raise AssertionError("decide ran PolicyNet.forward")

    handle = policy.net.register_forward_pre_hook(refuse_message_passing)
    try:
        assert policy.decide(make_stack_scene(4)) is not None
    finally:
        handle.remove()
