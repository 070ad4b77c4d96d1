"""The ``pairs`` decoder: p(o) p(g | o) over compatible pairs, its loss, choice and ranking."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from torch.nn.utils.rnn import pad_sequence

from manigraph_planner.gnn.checkpoint import load_checkpoint, save_checkpoint
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.pair_decoder import (
    category_compatible,
    joint_log_probs,
    padded_pair_loss,
    padded_pair_select,
    padded_valid_pairs,
)
from manigraph_shared.errors import ConfigError
from manigraph_training.batch_layouts import BATCH_LAYOUTS
from manigraph_training.dataset import Sample

BLOCK, BLOCK_GOAL, COVER, COVER_GOAL = 1.0, 2.0, 0.0, 3.0


def graph(codes: list[float], seed: int) -> Sample:
    """A sample whose nodes have the given category codes (objects: 0 or 1), random
    features otherwise; the expert's pair: the first object and the first goal it fits."""
    gen = torch.Generator().manual_seed(seed)
    x = torch.rand(len(codes), 5, generator=gen)
    x[:, 0] = torch.tensor(codes)
    is_object = x[:, 0] < 1.5
    first = int(is_object.nonzero()[0])
    goal = next(i for i, c in enumerate(codes) if c == 3 - codes[first])
    return Sample(x, is_object, first, goal)


SAMPLES = [
    graph([BLOCK, BLOCK, BLOCK_GOAL, BLOCK_GOAL, BLOCK_GOAL], 0),
    graph([COVER, BLOCK, BLOCK_GOAL, COVER_GOAL], 1),
    graph([BLOCK, BLOCK_GOAL], 2),
]


def pairs_net(seed: int = 0, arch: str = "sage") -> PolicyNet:
    torch.manual_seed(seed)
    return PolicyNet(ModelConfig(arch, decoder="pairs"))


def test_valid_pairs_are_an_object_and_a_goal_of_its_category_never_padding() -> None:
    x = pad_sequence([s.x for s in SAMPLES], batch_first=True)
    is_object = pad_sequence([s.is_object for s in SAMPLES], batch_first=True)
    mask = pad_sequence([torch.ones(len(s.x), dtype=torch.bool) for s in SAMPLES], True)
    valid = padded_valid_pairs(x, is_object, mask)
    assert valid.shape == (3, 5, 5)
    assert valid[0].nonzero().tolist() == [[o, g] for o in (0, 1) for g in (2, 3, 4)]
    assert valid[1].nonzero().tolist() == [[0, 3], [1, 2]]  # cover to cover goal only
    assert valid[2].nonzero().tolist() == [[0, 1]]  # the padding is in no pair
    assert category_compatible(torch.tensor([0.0, 1.0]), torch.tensor([2.0, 3.0])).tolist() == [
        [False, True],
        [True, False],
    ]


def test_the_loss_is_a_finite_mean_with_gradients_and_refuses_an_invalid_target() -> None:
    net = pairs_net()
    layout = BATCH_LAYOUTS["padded"]
    loss = layout.loss(net, SAMPLES)
    assert loss.shape == () and torch.isfinite(loss)
    loss.backward()
    assert all(p.grad is not None for p in net.parameters())
    # per graph: -log p(o*) - log p(g* | o*), by hand for the one-pair graph: p = 1 for both
    alone = layout.loss(net, [SAMPLES[2]])
    assert float(alone.detach()) == pytest.approx(0.0, abs=1e-6)
    x, is_object = SAMPLES[1].x.unsqueeze(0), SAMPLES[1].is_object.unsqueeze(0)
    mask = torch.ones_like(is_object)
    with pytest.raises(ValueError, match="pair target"):  # the cover into the block goal
        padded_pair_loss(
            *net.pairs_complete(x, mask),
            is_object,
            mask,
            padded_valid_pairs(x, is_object, mask),
            torch.tensor([0]),
            torch.tensor([2]),
        )


def test_the_pyg_reference_gives_the_padded_loss_and_choices() -> None:
    net = pairs_net(arch="gat").double()
    samples = [Sample(s.x.double(), s.is_object, s.object_index, s.goal_index) for s in SAMPLES]
    padded, pyg = BATCH_LAYOUTS["padded"], BATCH_LAYOUTS["pyg"]
    with torch.no_grad():
        assert float(padded.loss(net, samples)) == pytest.approx(float(pyg.loss(net, samples)))
    for a, b in zip(padded.choices(net, samples), pyg.choices(net, samples), strict=True):
        assert torch.equal(a, b)


def test_the_choice_is_the_argmax_of_p_o_times_p_g_given_o_over_valid_pairs() -> None:
    node_logits = torch.tensor([[0.0, 1.0, 0.0, 0.0]])  # object 1 likelier
    pair_logits = torch.zeros(1, 4, 4)
    pair_logits[0, 0, 2] = 5.0  # object 0 surely to goal 2
    pair_logits[0, 1, 3] = 0.1  # object 1 torn between goals 2 and 3
    is_object = torch.tensor([[True, True, False, False]])
    mask = torch.ones_like(is_object)
    valid = torch.zeros(1, 4, 4, dtype=torch.bool)
    valid[0, :2, 2:] = True
    objects, goals = padded_pair_select(node_logits, pair_logits, is_object, mask, valid)
    # log p(1) + log p(3 | 1) = -0.31 - 0.64 > log p(0) + log p(2 | 0) = -1.31 - 0.01
    assert (int(objects[0]), int(goals[0])) == (1, 3)
    joint = joint_log_probs(
        node_logits[0, :2].log_softmax(0), pair_logits[0, :2, 2:], valid[0, :2, 2:]
    )
    assert float(joint.exp().sum()) == pytest.approx(1.0)
    none = padded_pair_select(node_logits, pair_logits, is_object, mask, valid & False)
    assert [int(c[0]) for c in none] == [-1, -1]


def test_a_pairs_checkpoint_records_its_decoder_and_loads_to_the_same_scores(
    tmp_path: Path,
) -> None:
    net = pairs_net()
    path = save_checkpoint(tmp_path / "p.pt", net, training_config={}, data_hash="h")
    loaded, info = load_checkpoint(path, message_passing=False)
    assert info.model.decoder == "pairs" and info.model.to_dict()["decoder"] == "pairs"
    x = SAMPLES[0].x
    for a, b in zip(net.pairs_complete(x), loaded.pairs_complete(x), strict=True):
        assert torch.allclose(a, b)


def test_a_nodes_network_is_what_it_was_before_pairs() -> None:
    config = ModelConfig("sage")
    assert config.decoder == "nodes" and "decoder" not in config.to_dict()
    net = PolicyNet(config)
    assert not net.decodes_pairs and not any(k.startswith("pair") for k in net.state_dict())
    with pytest.raises(ValueError, match="no pair head"):
        net.pair_logits(SAMPLES[0].x)


@pytest.mark.parametrize(("decoder", "heads"), [("edges", "object-goal"), ("pairs", "dishwasher")])
def test_bad_decoders_are_refused_naming_the_field(decoder: str, heads: str) -> None:
    with pytest.raises(ConfigError, match="decoder"):
        ModelConfig("sage", decoder=decoder, heads=heads)
