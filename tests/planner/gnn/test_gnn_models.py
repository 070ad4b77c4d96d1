from __future__ import annotations

import pytest
import torch
from torch_geometric.data import Batch

from manigraph_planner.gnn.features import GraphState, graph_from_arrays
from manigraph_planner.gnn.models import ARCHITECTURES, ModelConfig, PolicyNet
from manigraph_planner.gnn.selection import selection_loss
from manigraph_shared.errors import ConfigError

ARCHS = sorted(ARCHITECTURES)


def random_graph(num_objects: int, num_goals: int, seed: int) -> GraphState:
    gen = torch.Generator().manual_seed(seed)
    category = torch.cat(
        [
            torch.randint(0, 2, (num_objects,), generator=gen),
            torch.randint(2, 4, (num_goals,), generator=gen),
        ]
    )
    position = torch.rand(num_objects + num_goals, 3, generator=gen)
    filled = torch.randint(0, 2, (num_objects + num_goals,), generator=gen)
    return graph_from_arrays(category, position, filled)


def make_net(arch: str, seed: int = 0, **kwargs: object) -> PolicyNet:
    torch.manual_seed(seed)
    return PolicyNet(ModelConfig(arch, **kwargs)).eval()  # type: ignore[arg-type]


def test_the_papers_four_architectures_are_registered() -> None:
    assert set(ARCHITECTURES) >= {"gcn", "sage", "gated", "gat"}


@pytest.mark.parametrize("arch", ARCHS)
def test_permuting_nodes_permutes_logits(arch: str) -> None:
    net = make_net(arch)
    graph = random_graph(5, 5, seed=1)
    perm = torch.randperm(graph.num_nodes, generator=torch.Generator().manual_seed(2))
    new_label = torch.empty_like(perm)
    new_label[perm] = torch.arange(graph.num_nodes)  # old node perm[k] becomes node k
    edges = new_label[graph.edge_index]
    edges = edges[:, torch.randperm(edges.shape[1], generator=torch.Generator().manual_seed(3))]
    with torch.no_grad():
        logits = net(graph.x, graph.edge_index)
        permuted = net(graph.x[perm], edges)
    torch.testing.assert_close(permuted, logits[perm], atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("arch", ARCHS)
def test_same_weights_run_on_any_graph_size(arch: str) -> None:
    net = make_net(arch)
    with torch.no_grad():
        for size in (4, 10, 80):
            graph = random_graph(size // 2, size - size // 2, seed=size)
            logits = net(graph.x, graph.edge_index)
            assert logits.shape == (size,)
            assert bool(torch.isfinite(logits).all())


@pytest.mark.parametrize("arch", ARCHS)
def test_nodes_see_their_neighbours(arch: str) -> None:
    net = make_net(arch)
    graph = random_graph(3, 3, seed=4)
    moved = graph.x.clone()
    moved[5, 1:4] += 0.5  # move the last goal only
    with torch.no_grad():
        before = net(graph.x, graph.edge_index)
        after = net(moved, graph.edge_index)
    assert not torch.allclose(before[:5], after[:5], atol=1e-6, rtol=0)


@pytest.mark.parametrize("arch", ARCHS)
def test_batched_forward_equals_forward_per_graph(arch: str) -> None:
    net = make_net(arch)
    graphs = [random_graph(2, 2, 5), random_graph(6, 4, 6), random_graph(40, 40, 7)]
    batch = Batch.from_data_list([g.to_data() for g in graphs])
    with torch.no_grad():
        batched = net(batch.x, batch.edge_index, batch.batch)
        one_by_one = torch.cat([net(g.x, g.edge_index) for g in graphs])
    torch.testing.assert_close(batched, one_by_one, atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("arch", ARCHS)
def test_loss_falls_when_overfitting_a_tiny_batch(arch: str) -> None:
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig(arch)).train()
    graphs = [random_graph(k, k, seed=10 + k) for k in (2, 3, 4, 5)]
    data = []
    for graph in graphs:  # target: the highest object and the lowest goal
        k = graph.num_objects
        obj = int(graph.x[:k, 3].argmax())
        goal = k + int(graph.x[k:, 3].argmin())
        targets = {"object_index": torch.tensor([obj]), "goal_index": torch.tensor([goal])}
        data.append(graph.to_data(**targets))
    batch = Batch.from_data_list(data)
    optimiser = torch.optim.Adam(net.parameters(), lr=1e-2)

    def loss() -> torch.Tensor:
        logits = net(batch.x, batch.edge_index, batch.batch)
        return selection_loss(
            logits, batch.is_object, batch.batch, batch.object_index, batch.goal_index
        )

    first = loss().item()
    for _ in range(50):
        optimiser.zero_grad()
        value = loss()
        value.backward()
        optimiser.step()
    last = loss().item()
    assert last < 0.5 * first, f"{arch}: loss {first:.3f} -> {last:.3f}"


@pytest.mark.parametrize("arch", ARCHS)
def test_feature_scale_multiplies_the_raw_features(arch: str) -> None:
    scale = (1.0, 10.0, 10.0, 10.0, 1.0)
    scaled = make_net(arch, seed=3, feature_scale=scale)
    plain = make_net(arch, seed=3)
    graph = random_graph(3, 3, seed=8)
    with torch.no_grad():
        expected = plain(graph.x * torch.tensor(scale), graph.edge_index)
        torch.testing.assert_close(scaled(graph.x, graph.edge_index), expected)
        assert not torch.allclose(plain(graph.x, graph.edge_index), expected)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"architecture": "transformer"}, "architecture"),
        ({"architecture": "sage", "hidden_channels": 0}, "hidden_channels"),
        ({"architecture": "sage", "num_layers": 2.5}, "num_layers"),
        ({"architecture": "sage", "in_channels": 6}, "in_channels"),
        ({"architecture": "sage", "feature_scale": (1.0, 1.0)}, "feature_scale"),
        ({"architecture": "sage", "feature_scale": (1, 1, 0, 1, 1)}, "feature_scale"),
    ],
)
def test_model_config_rejects_bad_values_naming_the_field(
    kwargs: dict[str, object], field: str
) -> None:
    with pytest.raises(ConfigError, match=rf"^{field}:") as caught:
        ModelConfig(**kwargs)  # type: ignore[arg-type]
    assert caught.value.field == field


def test_gated_needs_hidden_at_least_as_wide_as_the_features() -> None:
    with pytest.raises(ConfigError, match=r"^hidden_channels:"):
        PolicyNet(ModelConfig("gated", hidden_channels=4))


def test_model_config_round_trips_through_a_dict() -> None:
    config = ModelConfig("gat", hidden_channels=32, num_layers=2, feature_scale=(1, 2, 2, 2, 1))
    assert ModelConfig.from_dict(config.to_dict()) == config
    with pytest.raises(ConfigError, match=r"^dropout:"):
        ModelConfig.from_dict({**config.to_dict(), "dropout": 0.1})
