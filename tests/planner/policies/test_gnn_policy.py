from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
import torch

from manigraph_planner.gnn.checkpoint import save_checkpoint
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import Scene, SceneGoal, SceneObject, Vector3

SIZE = Vector3(x=0.04, y=0.04, z=0.04)


def checkpoint(tmp_path: Path, arch: str = "sage") -> Path:
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig(arch))
    return save_checkpoint(tmp_path / "policy.pt", net, training_config={}, data_hash="h")


def test_load_policy_opens_a_checkpoint_as_a_gnn_policy(
    tmp_path: Path, make_stack_scene: Callable[[int], Scene]
) -> None:
    policy = load_policy(str(checkpoint(tmp_path, "gat")))
    assert isinstance(policy, GNNPolicy)
    assert policy.name == "gnn-gat"
    assert policy.info is not None and policy.info.data_hash == "h"
    scene = make_stack_scene(3)
    decision = policy.decide(scene)
    assert decision is not None
    assert decision.object_id in {o.id for o in scene.objects}
    assert decision.goal_id in {g.id for g in scene.goals}


def test_decision_is_the_argmax_of_the_probabilities(
    tmp_path: Path, make_stack_scene: Callable[[int], Scene]
) -> None:
    policy = GNNPolicy.from_checkpoint(checkpoint(tmp_path))
    scene = make_stack_scene(5)
    probs = policy.probabilities(scene)
    assert probs.object_probs.sum().item() == pytest.approx(1.0)
    assert probs.goal_probs.sum().item() == pytest.approx(1.0)
    objects, goals = probs.objects(), probs.goals()
    decision = policy.decide(scene)
    assert decision is not None
    assert decision.object_id == max(objects, key=objects.__getitem__)
    assert decision.goal_id == max(goals, key=goals.__getitem__)


def test_ties_go_to_the_first_object_and_goal_in_scene_order(
    make_stack_scene: Callable[[int], Scene],
) -> None:
    net = PolicyNet(ModelConfig("gcn"))
    with torch.no_grad():
        for parameter in net.parameters():
            parameter.zero_()  # every logit is exactly 0
    scene = make_stack_scene(4)
    decision = GNNPolicy(net).decide(scene)
    assert decision is not None and (decision.object_id, decision.goal_id) == ("b0", "g0")


def test_hidden_objects_are_never_chosen() -> None:
    objects = [
        SceneObject(
            id="hidden",
            category="block",
            position=Vector3(x=0.5, y=0, z=0.02),
            size=SIZE,
            visible=False,
        ),
        SceneObject(id="seen", category="block", position=Vector3(x=0.3, y=0, z=0.02), size=SIZE),
    ]
    goals = [
        SceneGoal(
            id="closed-box", category="block", position=Vector3(x=0.1, y=0, z=0.02), visible=False
        ),
        SceneGoal(id="open", category="block", position=Vector3(x=0.2, y=0, z=0.02)),
    ]
    scene = Scene(episode_id="e", stamp=1.0, sequence=0, objects=objects, goals=goals)
    net = PolicyNet(ModelConfig("gcn"))
    with torch.no_grad():
        for parameter in net.parameters():
            parameter.zero_()  # ties: a hidden first node would win if it were a node
    decision = GNNPolicy(net).decide(scene)
    assert decision is not None and (decision.object_id, decision.goal_id) == ("seen", "open")


@pytest.mark.parametrize("missing", ["objects", "goals"])
def test_nothing_to_decide_without_visible_objects_or_goals(
    make_stack_scene: Callable[[int], Scene], missing: str
) -> None:
    scene = make_stack_scene(2)
    entities = getattr(scene, missing)
    hidden = [e.replace(visible=False) for e in entities]
    scene = scene.replace(**{missing: hidden})
    assert GNNPolicy(PolicyNet(ModelConfig("sage"))).decide(scene) is None


def test_load_policy_refuses_a_broken_checkpoint(tmp_path: Path) -> None:
    path = tmp_path / "broken.pt"
    path.write_bytes(b"not a checkpoint")
    with pytest.raises(PolicyError, match=r"^not a manigraph checkpoint: "):
        load_policy(str(path))
