"""The dense complete-graph path of every backbone equals PyG message passing, on one graph
and on a padded batch of graphs of different sizes."""

from __future__ import annotations

import pytest
import torch
from torch import nn
from torch.nn.utils.rnn import pad_sequence
from torch_geometric.data import Batch, Data
from torch_geometric.nn import GraphConv

from manigraph_planner.gnn.features import fully_connected_edge_index
from manigraph_planner.gnn.models import ARCHITECTURES, ConvStack, ModelConfig, PolicyNet
from manigraph_planner.gnn.models.complete_graph import (
    AttentionStructure,
    complete_edge_index,
    neighbour_mean,
    neighbour_softmax,
    neighbour_sum,
)

ARCHS = sorted(ARCHITECTURES)
SIZES = (1, 2, 3, 17, 80)
CONFIGS: tuple[dict[str, object], ...] = (
    {},  # the paper's sizes: 64 hidden, 3 layers
    {"hidden_channels": 8, "num_layers": 1, "feature_scale": (1.0, 10.0, 10.0, 10.0, 1.0)},
)


def random_features(num_nodes: int, seed: int, dtype: torch.dtype) -> torch.Tensor:
    """Category codes in [0, 3], positions in [-1, 1], filled flags: the graph-state ranges."""
    gen = torch.Generator().manual_seed(seed)
    codes = torch.randint(0, 4, (num_nodes, 1), generator=gen)
    position = 2 * torch.rand(num_nodes, 3, generator=gen) - 1
    filled = torch.randint(0, 2, (num_nodes, 1), generator=gen)
    return torch.cat([codes, position, filled], dim=1).to(dtype)


def random_net(arch: str, seed: int, **config: object) -> PolicyNet:
    torch.manual_seed(seed)
    net = PolicyNet(ModelConfig(arch, **config)).eval()  # type: ignore[arg-type]
    with torch.no_grad():  # biases start at zero; random ones test that they are applied
        for parameter in net.parameters():
            parameter.add_(0.1 * torch.randn_like(parameter))
    return net


@pytest.mark.parametrize("config", CONFIGS, ids=["paper", "small-scaled"])
@pytest.mark.parametrize("arch", ARCHS)
def test_dense_path_equals_message_passing_in_float64(arch: str, config: dict[str, object]) -> None:
    net = random_net(arch, seed=len(config), **config).double()
    for num_nodes in SIZES:
        x = random_features(num_nodes, seed=num_nodes, dtype=torch.float64)
        with torch.no_grad():
            expected = net(x, fully_connected_edge_index(num_nodes))
            dense = net.forward_complete(x)
        torch.testing.assert_close(dense, expected, atol=1e-5, rtol=0, msg=f"N={num_nodes}")


@pytest.mark.parametrize("arch", ARCHS)
def test_dense_path_is_as_accurate_as_message_passing_in_float32(arch: str) -> None:
    """In float32 both paths round, in different summation orders; against a float64
    reference the dense path is no less accurate. (An untrained GCN sums 79 neighbours per
    layer, so its logits reach 1e4 and rounding alone moves them by ~1e-2.)"""
    net = random_net(arch, seed=5)
    for num_nodes in SIZES:
        x = random_features(num_nodes, seed=100 + num_nodes, dtype=torch.float32)
        edge_index = fully_connected_edge_index(num_nodes)
        with torch.no_grad():
            message_passing = net(x, edge_index).double()
            dense = net.forward_complete(x).double()
            reference = net.double()(x.double(), edge_index)
        net.float()
        message_passing_error = (message_passing - reference).abs().max().item()
        dense_error = (dense - reference).abs().max().item()
        assert dense_error <= max(2 * message_passing_error, 1e-5), f"N={num_nodes}"


@pytest.mark.parametrize("arch", ARCHS)
def test_dense_path_handles_an_empty_graph(arch: str) -> None:
    with torch.no_grad():
        logits = random_net(arch, seed=0).forward_complete(torch.zeros(0, 5))
    assert logits.shape == (0,)


def parameter_gradients(net: PolicyNet, logits: torch.Tensor) -> dict[str, torch.Tensor]:
    logits.square().sum().backward()
    return {name: p.grad for name, p in net.named_parameters() if p.grad is not None}


@pytest.mark.parametrize("arch", ARCHS)
def test_dense_path_has_the_same_gradients(arch: str) -> None:
    """The dense path is the same function of the same parameters (every one of them)."""
    x = random_features(6, seed=3, dtype=torch.float64)
    message_passing, dense = random_net(arch, seed=2).double(), random_net(arch, seed=2).double()
    expected = parameter_gradients(
        message_passing, message_passing(x, fully_connected_edge_index(6))
    )
    got = parameter_gradients(dense, dense.forward_complete(x))
    assert got.keys() == expected.keys() == dict(dense.named_parameters()).keys()
    for name, grad in expected.items():
        torch.testing.assert_close(got[name], grad, atol=1e-8, rtol=1e-8, msg=name)


def test_a_conv_stack_without_a_dense_layer_falls_back_to_message_passing() -> None:
    class PlainGraphConvStack(ConvStack):  # not registered: a future architecture
        def make_conv(self, in_channels: int, out_channels: int) -> nn.Module:
            return GraphConv(in_channels, out_channels, aggr="max")

    torch.manual_seed(0)
    backbone = PlainGraphConvStack(5, 16, 2)
    x = random_features(7, seed=1, dtype=torch.float32)
    with torch.no_grad():
        expected = backbone(x, fully_connected_edge_index(7))
        torch.testing.assert_close(backbone.forward_complete(x), expected)


def test_neighbour_reductions_leave_out_the_node_itself() -> None:
    x = torch.tensor([[1.0, 10.0], [2.0, 20.0], [4.0, 40.0]])
    torch.testing.assert_close(neighbour_sum(x), torch.tensor([[6.0, 60], [5, 50], [3, 30]]))
    torch.testing.assert_close(neighbour_mean(x), neighbour_sum(x) / 2)
    weights = neighbour_softmax(torch.tensor([[0.0, 1.0, 2.0], [5.0, 0.0, 5.0], [0, 0, 9.0]]))
    assert torch.equal(weights.diagonal(), torch.zeros(3))
    torch.testing.assert_close(weights.sum(dim=1), torch.ones(3))
    torch.testing.assert_close(weights[0, 1:], torch.tensor([1.0, 2.0]).softmax(0))
    torch.testing.assert_close(weights[1], torch.tensor([0.5, 0.0, 0.5]))


def test_a_lone_node_has_no_neighbours_to_reduce() -> None:
    x = torch.tensor([[3.0, 4.0]])
    assert torch.equal(neighbour_sum(x), torch.zeros(1, 2))
    assert torch.equal(neighbour_mean(x), torch.zeros(1, 2))
    assert torch.equal(neighbour_softmax(torch.tensor([[7.0]])), torch.zeros(1, 1))


# ---- padded batches: B graphs of different sizes as (B, N_max, F) with a node mask ----

BATCH_SIZES = (3, 1, 17, 2, 40, 2)  # mixed, with lone nodes and pairs, largest not first


def padded(graphs: list[torch.Tensor], padding: float = 0.0) -> tuple[torch.Tensor, torch.Tensor]:
    """``(x, mask)`` of a padded batch; ``padding`` fills the padded slots."""
    x = pad_sequence(graphs, batch_first=True, padding_value=padding)
    sizes = torch.tensor([g.shape[0] for g in graphs])
    return x, torch.arange(x.shape[1]) < sizes.unsqueeze(1)


def pyg_logits(net: PolicyNet, graphs: list[torch.Tensor]) -> list[torch.Tensor]:
    """Per-graph logits of one PyG batch of the disjoint complete graphs."""
    batch = Batch.from_data_list(
        [Data(x=g, edge_index=fully_connected_edge_index(g.shape[0])) for g in graphs]
    )
    logits = net(batch.x, batch.edge_index, batch.batch)
    return list(logits.split([g.shape[0] for g in graphs]))


def random_batch(seed: int, dtype: torch.dtype = torch.float64) -> list[torch.Tensor]:
    return [random_features(n, seed=seed + i, dtype=dtype) for i, n in enumerate(BATCH_SIZES)]


@pytest.mark.parametrize("config", CONFIGS, ids=["paper", "small-scaled"])
@pytest.mark.parametrize("arch", ARCHS)
def test_padded_batch_equals_message_passing_per_graph_in_float64(
    arch: str, config: dict[str, object]
) -> None:
    net = random_net(arch, seed=len(config), **config).double()
    graphs = random_batch(seed=10)
    x, mask = padded(graphs, padding=3.0)  # non-zero padding must not leak into real nodes
    with torch.no_grad():
        logits = net.forward_complete(x, mask)
        expected = pyg_logits(net, graphs)
    assert logits.shape == mask.shape
    assert bool(logits.isfinite().all())
    for b, graph_logits in enumerate(expected):
        got = logits[b, : graph_logits.shape[0]]
        torch.testing.assert_close(got, graph_logits, atol=1e-6, rtol=0, msg=f"graph {b}")


@pytest.mark.parametrize("arch", ARCHS)
def test_padded_batch_has_the_same_gradients_as_message_passing(arch: str) -> None:
    graphs = random_batch(seed=20)
    x, mask = padded(graphs, padding=3.0)
    message_passing, dense = random_net(arch, seed=4).double(), random_net(arch, seed=4).double()
    expected = parameter_gradients(message_passing, torch.cat(pyg_logits(message_passing, graphs)))
    got = parameter_gradients(dense, dense.forward_complete(x, mask)[mask])
    assert got.keys() == expected.keys() == dict(dense.named_parameters()).keys()
    for name, grad in expected.items():
        torch.testing.assert_close(got[name], grad, atol=1e-8, rtol=1e-8, msg=name)


def test_a_conv_stack_without_a_dense_layer_runs_a_padded_batch_by_message_passing() -> None:
    class PlainGraphConvStack(ConvStack):
        def make_conv(self, in_channels: int, out_channels: int) -> nn.Module:
            return GraphConv(in_channels, out_channels, aggr="max")

    torch.manual_seed(0)
    backbone = PlainGraphConvStack(5, 16, 2).double()
    graphs = random_batch(seed=30)
    x, mask = padded(graphs)
    with torch.no_grad():
        hidden = backbone.forward_complete(x, mask)
        for b, graph in enumerate(graphs):
            expected = backbone.forward_complete(graph)
            torch.testing.assert_close(hidden[b, : graph.shape[0]], expected, msg=f"graph {b}")


def test_padded_edges_join_every_pair_of_real_nodes_within_a_graph() -> None:
    mask = torch.tensor([[True, True, True], [True, True, False], [True, False, False]])
    edge_index = complete_edge_index(mask)
    expected = torch.cat([fully_connected_edge_index(3), fully_connected_edge_index(2) + 3], 1)
    assert torch.equal(edge_index, expected)  # the lone node of graph 2 has no edges


def test_padded_reductions_ignore_padding_and_the_node_itself() -> None:
    x, mask = padded([torch.tensor([[1.0], [2.0], [4.0]]), torch.tensor([[8.0]])], padding=100.0)
    assert torch.equal(neighbour_sum(x, mask)[0], torch.tensor([[6.0], [5.0], [3.0]]))
    assert torch.equal(neighbour_sum(x, mask)[1, 0], torch.zeros(1))  # a lone node
    assert torch.equal(neighbour_mean(x, mask)[0], torch.tensor([[3.0], [2.5], [1.5]]))
    assert torch.equal(neighbour_mean(x, mask)[1, 0], torch.zeros(1))
    weights = neighbour_softmax(torch.zeros(2, 3, 3), mask)
    torch.testing.assert_close(weights[0], (1 - torch.eye(3)) / 2)
    assert torch.equal(weights[1], torch.zeros(3, 3))  # no neighbours, no padded sources


def test_a_graph_without_neighbours_keeps_attention_gradients_finite() -> None:
    scores = torch.zeros(2, 2, 2, requires_grad=True)
    mask = torch.tensor([[True, True], [True, False]])
    neighbour_softmax(scores, mask).sum().backward()
    assert scores.grad is not None and bool(scores.grad.isfinite().all())


def test_attention_structure_gives_the_masked_softmax_bit_for_bit() -> None:
    """GAT's scores pushed far down off the edges give exactly the weights and gradients of
    masking them (neighbour_softmax) at every real node, lone nodes included: its rows at
    padding differ, and nothing reads them."""
    x, mask = padded(random_batch(seed=40, dtype=torch.float32), padding=3.0)
    generator = torch.Generator().manual_seed(2)
    target, source = (10 * torch.randn(mask.shape, generator=generator) for _ in range(2))
    # Padded nodes' outputs are never read, so nothing flows back into their rows.
    upstream = torch.randn(*mask.shape, mask.shape[1], generator=generator) * mask.unsqueeze(-1)
    results = []
    for structured in (False, True):
        t, s = target.clone().requires_grad_(), source.clone().requires_grad_()
        if structured:
            structure = AttentionStructure.of(x, mask)
            scores = torch.nn.functional.leaky_relu(structure.scores(t, s), 0.2, inplace=True)
            weights = structure.softmax(scores)
        else:
            scores = torch.nn.functional.leaky_relu(t.unsqueeze(-1) + s.unsqueeze(-2), 0.2)
            weights = neighbour_softmax(scores, mask)
        (weights * upstream).sum().backward()
        assert t.grad is not None and s.grad is not None
        results.append((weights[mask], t.grad[mask], s.grad[mask]))
    for masked, structured in zip(*results, strict=True):
        assert torch.equal(structured, masked)
