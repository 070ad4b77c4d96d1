"""Several dishwasher networks decoded as one, from one checkpoint."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from manigraph_dishwasher.planner.ensemble import DishEnsembleNet
from manigraph_dishwasher.planner.features import dish_scene_to_graph
from manigraph_dishwasher.planner.gnn_policy import (
    DishwasherGNNPolicy,
    decision_from_heads,
)
from manigraph_dishwasher.planner.net import DishHeads, DishPolicyNet
from manigraph_dishwasher.training.loop import DishTrainConfig, member_seed
from manigraph_planner.gnn.checkpoint import load_checkpoint, save_checkpoint
from manigraph_planner.gnn.models import ModelConfig
from manigraph_planner.policies import load_policy
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.geometric.backend import GeometricBackend

#: The model fields of every dishwasher checkpoint written before ensembles.
PLAIN_MODEL_FIELDS = {
    "architecture",
    "hidden_channels",
    "num_layers",
    "in_channels",
    "feature_scale",
    "heads",
}


def member(seed: int) -> DishPolicyNet:
    torch.manual_seed(seed)
    return DishPolicyNet(DishTrainConfig("sage", hidden_channels=16).model_config())


def rack_top_out_scene(objects: int = 4):  # type: ignore[no-untyped-def]
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=objects), 0.0)
    # The backend's one world (``world``; ``dishwasher`` before the sim's families).
    world = getattr(backend, "dishwasher", None) or backend.world
    world.toggle("rack_top")  # type: ignore[union-attr]
    return backend.scene(1.0)


def test_an_ensemble_checkpoint_round_trips_and_decodes_the_mean_of_its_members(
    tmp_path: Path,
) -> None:
    members = [member(seed) for seed in (0, 1, 2)]
    path = save_checkpoint(
        tmp_path / "e.pt", DishEnsembleNet.of(members), training_config={}, data_hash="x"
    )
    loaded = load_checkpoint(path)
    assert isinstance(loaded.net, DishEnsembleNet) and loaded.info.model.ensemble == 3
    scene = rack_top_out_scene()
    graph = dish_scene_to_graph(scene)
    with torch.no_grad():
        each = [m.heads_complete(graph.x) for m in members]
        mean_logp = DishHeads(
            torch.stack([h.node for h in each]).mean(0),  # one softmax per dish/slot subset
            torch.stack([h.orientation.log_softmax(-1) for h in each]).mean(0),
            torch.stack([h.tray.log_softmax(-1) for h in each]).mean(0),
        )
        heads = loaded.net.heads_complete(graph.x)
    assert torch.allclose(heads.tray.log_softmax(-1), mean_logp.tray.log_softmax(-1), atol=1e-6)
    assert torch.allclose(
        heads.orientation.log_softmax(-1), mean_logp.orientation.log_softmax(-1), atol=1e-6
    )
    policy = load_policy(str(path))
    assert isinstance(policy, DishwasherGNNPolicy)
    assert policy.decide(scene) == decision_from_heads(graph, mean_logp)
    # ... which is not simply one member's decision in general: the members differ.
    assert not torch.allclose(each[0].tray, each[1].tray)


def test_a_single_network_checkpoint_is_written_and_loaded_as_before(tmp_path: Path) -> None:
    path = save_checkpoint(tmp_path / "d.pt", member(0), training_config={}, data_hash="x")
    payload = torch.load(path, weights_only=True)
    assert set(payload["model"]) == PLAIN_MODEL_FIELDS
    assert not any(key.startswith("members.") for key in payload["state_dict"])
    loaded = load_checkpoint(path)
    assert type(loaded.net) is DishPolicyNet and loaded.info.model.ensemble == 1


def test_only_the_dishwasher_heads_take_members() -> None:
    with pytest.raises(ConfigError, match="ensemble"):
        ModelConfig("sage", ensemble=2)
    with pytest.raises(ConfigError, match="ensemble"):
        ModelConfig("sage", heads="dishwasher", ensemble=0)


def test_members_have_their_own_seeds_and_the_first_is_the_training_seed() -> None:
    assert member_seed(2, 0) == 2
    seeds = {member_seed(s, m) for s in range(6) for m in range(5)}
    assert len(seeds) == 30


def test_training_several_members_makes_an_ensemble_whose_first_is_the_single_net(
    tmp_path: Path,
) -> None:
    from manigraph_dishwasher.planner.expert import dishwasher_expert
    from manigraph_dishwasher.training.loop import load_dish_demonstrations, train_dish
    from manigraph_lab.demo_recording import DemoProtocol, record_demos

    path = tmp_path / "demos.mcap"
    record_demos(
        dishwasher_expert("top-bottom"), DemoProtocol(("dishwasher",), (4,), 2, 0, 4), path
    )
    demos = load_dish_demonstrations([path])
    single, _ = train_dish(
        demos, DishTrainConfig("sage", 3, epochs=2, hidden_channels=8, members=1)
    )
    assert type(single) is DishPolicyNet
    pair, metrics = train_dish(
        demos, DishTrainConfig("sage", 3, epochs=2, hidden_channels=8, members=2)
    )
    assert isinstance(pair, DishEnsembleNet) and metrics["member_seeds"] == [3, 1003]
    first, second = pair.members
    for name, value in single.state_dict().items():
        assert torch.equal(first.state_dict()[name], value)
    assert not torch.equal(second.state_dict()["head.weight"], single.state_dict()["head.weight"])
