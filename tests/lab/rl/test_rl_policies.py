"""The GNN actor-critic: the IL network's pair logits, the IL decoder's decisions."""

from __future__ import annotations

import numpy as np
import torch

from manigraph_lab.rl.baselines import BASELINES, PPOSettings, Stage
from manigraph_lab.rl.env import StackEnv
from manigraph_lab.rl.policies import GraphFeatures, MaskablePPOPolicy, as_gnn_policy, policy_net
from manigraph_planner.gnn.features import scene_to_graph

TINY = PPOSettings(
    steps_per_stage=16, n_steps=16, batch_size=8, n_epochs=1, blocks=(2, 3), hidden_channels=8
)


def test_pair_logits_are_object_plus_goal_node_logits() -> None:
    env = StackEnv(3, max_blocks=4)
    observation, _ = env.reset(seed=0)
    features = GraphFeatures(env.observation_space, "sage", hidden_channels=8, num_layers=2)
    batch = {key: torch.as_tensor(value).unsqueeze(0) for key, value in observation.items()}
    out = features(batch)[0]
    logits = features.net.forward_complete(scene_to_graph(env.scene).x)  # unpadded graph
    pairs = out[:16].view(4, 4)
    expected = logits[:3].unsqueeze(1) + logits[3:].unsqueeze(0)
    torch.testing.assert_close(pairs[:3, :3], expected, rtol=1e-5, atol=1e-5)
    assert out.shape == (16 + 8,)


def test_model_action_is_the_gnn_policys_decision() -> None:
    baseline = BASELINES["rl-gnn-seq"]
    env = baseline.make_env(Stage("K3", (3,)), TINY)
    model = baseline.new_model(env, TINY, seed=0)
    # Perturb the head so that decisions are not decided by ties.
    with torch.no_grad():
        policy_net(model).head.bias.add_(0.1)
        for p in policy_net(model).parameters():
            p.add_(0.3 * torch.randn_like(p))
    gnn = as_gnn_policy(model)
    for seed in range(5):
        observation, _ = env.reset(seed=seed)
        action, _ = model.predict(observation, action_masks=env.action_masks(), deterministic=True)
        o, g = env.layout.pair(int(action))
        decision = gnn.decide(env.scene)
        assert decision is not None
        assert (decision.object_id, decision.goal_id) == (
            env.scene.objects[o].id,
            env.scene.goals[g].id,
        )


def test_mlp_model_decides_only_allowed_pairs() -> None:
    baseline = BASELINES["rl-mlp"]
    env = baseline.make_env(Stage("K3", (3,)), TINY)
    policy = baseline.policy(baseline.new_model(env, TINY, seed=0), env)
    assert isinstance(policy, MaskablePPOPolicy)
    env.reset(seed=3)
    decision = policy.decide(env.scene)
    assert decision is not None
    action = env.action_of(decision.object_id, decision.goal_id)
    assert env.action_masks()[action]
    assert np.count_nonzero(env.action_masks()) == 9
