"""The trainer's padded batches compute what PyG batches compute, and train the same way."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest
import torch

from manigraph_blocks.training.augment import Augmentation
from manigraph_planner.gnn.features import scene_to_graph
from manigraph_planner.gnn.models import ARCHITECTURES, ModelConfig, PolicyNet
from manigraph_shared.messages import Scene
from manigraph_training.batch_layouts import BATCH_LAYOUTS
from manigraph_training.dataset import Demonstrations, Sample
from manigraph_training.padded_batch import PackedSamples, PaddedBatch, size_groups
from manigraph_training.trainer import TrainConfig, accuracy, train

ARCHS = sorted(ARCHITECTURES)


@pytest.fixture
def samples(make_stack_scene: Callable[[int], Scene]) -> list[Sample]:
    """K-block stacking states of 2 to 18 nodes, in mixed order; the expert's move is the
    top block (node K - 1) onto the lowest goal (node K)."""
    out = []
    for k in (3, 1, 5, 2, 9, 4, 1, 7):
        graph = scene_to_graph(make_stack_scene(k))
        out.append(Sample(graph.x, graph.is_object, object_index=k - 1, goal_index=k))
    return out


def test_a_padded_batch_pads_every_graph_to_the_largest(samples: list[Sample]) -> None:
    batch = PaddedBatch.from_samples(samples)
    assert batch.num_graphs == len(samples)
    assert batch.x.shape == (len(samples), 18, 5)
    assert batch.mask.sum(dim=1).tolist() == [s.x.shape[0] for s in samples]
    for b, sample in enumerate(samples):
        n = sample.x.shape[0]
        assert torch.equal(batch.x[b, :n], sample.x) and not bool(batch.x[b, n:].any())
        assert torch.equal(batch.is_object[b, :n], sample.is_object)
        assert not bool(batch.is_object[b, n:].any())
    assert batch.object_index.tolist() == [s.object_index for s in samples]
    assert batch.goal_index.tolist() == [s.goal_index for s in samples]


def test_a_packed_training_set_gathers_the_same_padded_batches(samples: list[Sample]) -> None:
    packed = PackedSamples.pack(samples)
    assert len(packed) == len(samples)
    for indices in ([0, 1, 2, 3, 4, 5, 6, 7], [4, 1], [6], [7, 2, 6]):
        got = packed.padded(indices)
        expected = PaddedBatch.from_samples([samples[i] for i in indices])
        for field in ("x", "mask", "is_object", "object_index", "goal_index"):
            a, b = getattr(got, field), getattr(expected, field)
            assert a.dtype == b.dtype and torch.equal(a, b), (indices, field)


def test_size_groups_bound_the_padding_of_every_graph() -> None:
    sizes = [11, 6, 81, 12, 13, 40, 6, 25, 9]
    groups = size_groups(sizes, max_ratio=2.0)
    assert [[sizes[i] for i in group] for group in groups] == [
        [6, 6, 9, 11, 12],
        [13, 25],
        [40],
        [81],  # more than twice 40
    ]
    assert sorted(i for group in groups for i in group) == list(range(len(sizes)))
    assert size_groups(sizes, max_ratio=100.0) == [sorted(range(9), key=sizes.__getitem__)]


@pytest.mark.parametrize("arch", ARCHS)
def test_both_layouts_give_the_same_loss_gradients_and_choices(
    arch: str, samples: list[Sample]
) -> None:
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig(arch)).double()
    samples = [s.with_x(s.x.double()) for s in samples]
    losses, gradients, choices = {}, {}, {}
    for name, layout in BATCH_LAYOUTS.items():
        net.zero_grad()
        losses[name] = layout.loss(net, samples)
        losses[name].backward()
        gradients[name] = {
            n: p.grad.clone() for n, p in net.named_parameters() if p.grad is not None
        }
        with torch.no_grad():
            choices[name] = layout.choices(net, samples)
    torch.testing.assert_close(losses["padded"], losses["pyg"], atol=1e-6, rtol=0)
    assert (
        gradients["padded"].keys() == gradients["pyg"].keys() == dict(net.named_parameters()).keys()
    )
    for name, grad in gradients["pyg"].items():
        torch.testing.assert_close(gradients["padded"][name], grad, atol=1e-6, rtol=1e-6, msg=name)
    for padded, pyg in zip(choices["padded"], choices["pyg"], strict=True):
        assert padded.tolist() == pyg.tolist()
    assert accuracy(net, samples, "padded") == accuracy(net, samples, "pyg")


def loss_curve(demos: Demonstrations, config: TrainConfig) -> tuple[list[float], dict[str, object]]:
    curve: list[float] = []
    _, metrics = train(demos, config, on_epoch=lambda _, loss: curve.append(loss))
    return curve, metrics


@pytest.fixture
def default_dtype(request: pytest.FixtureRequest) -> Iterator[torch.dtype]:
    """Networks built while the test runs take this dtype (the trainer builds its own)."""
    previous = torch.get_default_dtype()
    torch.set_default_dtype(request.param)
    yield request.param
    torch.set_default_dtype(previous)


@pytest.mark.parametrize(
    ("default_dtype", "tolerance"),
    # float64 shows the two layouts train identically. In float32 their rounding differs,
    # and Adam scales gradients that are zero up to rounding (e.g. the head bias: a softmax
    # ignores a shift of all logits) to full-size steps, so the curves drift apart slowly.
    [(torch.float64, 2e-4), (torch.float32, 2e-2)],
    ids=["float64", "float32"],
    indirect=["default_dtype"],
)
@pytest.mark.parametrize("arch", ARCHS)
def test_a_short_training_run_follows_the_same_loss_curve_on_both_layouts(
    arch: str, samples: list[Sample], default_dtype: torch.dtype, tolerance: float
) -> None:
    samples = [s.with_x(s.x.to(default_dtype)) for s in samples]
    demos = Demonstrations(samples, data_hash="stack", episodes=1, skipped=0)
    runs = {}
    for layout in BATCH_LAYOUTS:
        config = TrainConfig(
            architecture=arch,
            epochs=6,
            batch_size=3,  # several batches of mixed sizes per epoch
            augmentation=Augmentation(copies=0),
            batch_layout=layout,
        )
        runs[layout] = loss_curve(demos, config)
    (padded_curve, padded), (pyg_curve, pyg) = runs["padded"], runs["pyg"]
    assert len(padded_curve) == len(pyg_curve) == 6  # every epoch
    assert padded_curve == pytest.approx(pyg_curve, abs=tolerance)
    assert padded["final_loss"] == pytest.approx(pyg["final_loss"], abs=tolerance)


def test_an_unknown_batch_layout_is_refused() -> None:
    with pytest.raises(ValueError, match=r"^batch_layout: 'sparse' is not one of: padded, pyg"):
        TrainConfig(batch_layout="sparse")
