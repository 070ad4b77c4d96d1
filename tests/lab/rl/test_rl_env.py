"""The Gymnasium environment: the paper's state, masked action and dense reward."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import manigraph_lab.rl  # noqa: F401  (registers manigraph/Stack-v0)
from manigraph_lab.rl import ENV_ID
from manigraph_lab.rl.env import TRAIN_SEED_BASE, SlotLayout, StackEnv
from manigraph_planner.gnn.features import scene_to_graph
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.geometric.backend import GeometricBackend


def test_registered_env_passes_gymnasiums_checker() -> None:
    env = gymnasium.make(ENV_ID, blocks=3)
    check_env(env.unwrapped, skip_render_check=True)
    assert env.action_space.n == 9
    assert env.observation_space["nodes"].shape == (6, 5)


def test_observation_is_the_planners_graph_state_in_slots() -> None:
    env = StackEnv(3, max_blocks=5)
    observation, info = env.reset(seed=1)
    graph = scene_to_graph(env.scene)
    assert info["episode_seed"] >= TRAIN_SEED_BASE
    np.testing.assert_array_equal(observation["nodes"][:3], graph.x[:3].numpy())
    np.testing.assert_array_equal(observation["nodes"][5:8], graph.x[3:].numpy())
    assert observation["node_mask"].tolist() == [1, 1, 1, 0, 0, 1, 1, 1, 0, 0]
    assert not observation["nodes"][[3, 4, 8, 9]].any()


def test_mask_allows_exactly_the_real_compatible_pairs() -> None:
    stack = StackEnv(3, max_blocks=4)
    stack.reset(seed=0)
    mask = stack.action_masks().reshape(4, 4)
    expected = np.zeros((4, 4), dtype=bool)
    expected[:3, :3] = True
    np.testing.assert_array_equal(mask, expected)

    # A scene with covers: a cover may only go to a cover goal, a block to a block goal.
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="m", task="box-pack", blocks=3, seed=0), 0.0)
    graph = scene_to_graph(backend.scene(0.0))
    layout = SlotLayout(8, 8)
    _, flat = layout.encode(graph)
    codes = graph.x[:, 0].round().int().tolist()
    k = graph.num_objects
    assert {0, 1} <= set(codes[:k]) and {2, 3} <= set(codes[k:])
    for o in range(8):
        for g in range(8):
            real = o < k and g < graph.num_nodes - k
            fits = real and (codes[o], codes[k + g]) in {(1, 2), (0, 3)}
            assert flat[o * 8 + g] == fits, (o, g)


def test_expert_rollout_returns_exactly_one_and_succeeds() -> None:
    expert = load_policy("expert")
    for blocks in (2, 5, 9):
        env = StackEnv(blocks)
        env.reset(seed=blocks)
        total, done, info = 0.0, False, {}
        while not done:
            decision = expert.decide(env.scene)
            assert decision is not None
            action = env.action_of(decision.object_id, decision.goal_id)
            assert env.action_masks()[action]
            _, reward, terminated, truncated, info = env.step(action)
            total += reward
            done = terminated or truncated
        assert terminated and info["is_success"]
        assert total == pytest.approx(1.0)


def test_failed_and_masked_actions_earn_nothing_and_the_budget_truncates() -> None:
    env = StackEnv(3)
    env.reset(seed=0)
    bottom = min(range(3), key=lambda o: env.scene.objects[o].position.z)
    covered = env.action_of(env.scene.objects[bottom].id, env.scene.goals[0].id)
    steps, truncated = 0, False
    while not truncated:
        action = covered if steps % 2 else 4 * 3  # 12 is outside the 9 actions: masked
        _, reward, terminated, truncated, info = env.step(action)
        steps += 1
        assert reward == 0.0 and not terminated and not info["ok"]
    assert steps == 2 * 3 + 4  # the task's step budget, failed attempts included


def test_same_seed_same_episodes_and_mixed_k_draws_every_k() -> None:
    first, second = StackEnv((2, 3, 4)), StackEnv((2, 3, 4))
    a, _ = first.reset(seed=7)
    b, _ = second.reset(seed=7)
    np.testing.assert_array_equal(a["nodes"], b["nodes"])
    drawn = {first.reset()[1]["blocks"] for _ in range(40)}
    assert drawn == {2, 3, 4}


def test_bad_blocks_are_refused_naming_the_field() -> None:
    with pytest.raises(ConfigError, match="blocks"):
        StackEnv(0)
    with pytest.raises(ConfigError, match="max_blocks"):
        StackEnv(5, max_blocks=3)
