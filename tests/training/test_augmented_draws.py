"""The background draws give what drawing in line gives, end their worker, and report errors."""

from __future__ import annotations

from dataclasses import replace

import pytest
import torch

from manigraph_blocks.training.augment import Augmentation
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.policies import load_policy
from manigraph_training.augmented_draws import (
    AugmentedDraws,
    InlineDraws,
    PackedDraw,
    draw_epochs,
)
from manigraph_training.dataset import Demonstrations, Sample, load_demonstrations
from manigraph_training.recipes import augmentation_for
from manigraph_training.trainer import TrainConfig, train


@pytest.fixture(scope="module")
def demos(tmp_path_factory: pytest.TempPathFactory) -> Demonstrations:
    path = tmp_path_factory.mktemp("demos") / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=4), path, progress=None)  # type: ignore[arg-type]
    return load_demonstrations([path])


def assert_same_samples(a: list[Sample], b: list[Sample]) -> None:
    assert len(a) == len(b)
    for i, (s, t) in enumerate(zip(a, b, strict=True)):
        assert torch.equal(s.x, t.x), i
        assert torch.equal(s.is_object, t.is_object), i
        assert (s.object_index, s.goal_index) == (t.object_index, t.goal_index), i


def test_draw_epochs_are_the_first_and_every_resample() -> None:
    assert draw_epochs(150, 10) == [1, 11, 21, 31, 41, 51, 61, 71, 81, 91, 101, 111, 121, 131, 141]
    assert draw_epochs(150, 0) == [1]
    assert draw_epochs(5, 10) == [1]


def test_background_draws_equal_inline_draws_in_order(demos: Demonstrations) -> None:
    augmentation = replace(augmentation_for("sage"), copies=2)  # with the structural steps
    inline = InlineDraws(augmentation, demos.samples, seed=7)
    with AugmentedDraws(augmentation, demos.samples, seed=7, count=3) as background:
        for _ in range(3):
            assert_same_samples(background.take(), inline.take())


def test_a_packed_draw_unpacks_to_the_same_samples(demos: Demonstrations) -> None:
    samples = Augmentation(copies=1).apply(demos.samples, torch.Generator().manual_seed(0))
    assert_same_samples(PackedDraw.pack(samples).unpack(), samples)


def test_training_with_background_draws_equals_training_with_inline_draws(
    demos: Demonstrations, monkeypatch: pytest.MonkeyPatch
) -> None:
    from manigraph_training import trainer

    config = TrainConfig(
        architecture="sage",
        epochs=4,
        resample_every=2,
        augmentation=replace(augmentation_for("sage"), copies=1),
    )
    background, _ = train(demos, config, progress=None)
    monkeypatch.setattr(trainer, "AugmentedDraws", _InlineAsContext)
    reference, _ = train(demos, config, progress=None)
    for (name, p), (_, q) in zip(
        background.state_dict().items(), reference.state_dict().items(), strict=True
    ):
        assert torch.equal(p, q), name


class _InlineAsContext(InlineDraws):
    """The in-line draws in :class:`AugmentedDraws`' place (same constructor, a context)."""

    def __init__(self, augmentation: Augmentation, demos: list[Sample], seed: int, count: int):
        super().__init__(augmentation, demos, seed)

    def __enter__(self) -> _InlineAsContext:
        return self

    def __exit__(self, *exc_info: object) -> None:
        pass


def test_training_gives_back_its_threads(demos: Demonstrations) -> None:
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        config = TrainConfig(
            architecture="sage", epochs=2, resample_every=1, augmentation=Augmentation(copies=1)
        )
        train(demos, config, progress=None)
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_closing_early_ends_the_worker(demos: Demonstrations) -> None:
    draws = AugmentedDraws(Augmentation(copies=1), demos.samples, seed=0, count=50)
    draws.take()
    draws.close()
    with pytest.raises(RuntimeError, match="closed"):
        draws.take()


def test_a_failing_draw_is_raised_in_the_trainer() -> None:
    broken = [Sample(torch.zeros(3, 2), torch.ones(3, dtype=torch.bool), 0, 1)]  # 2 features
    with pytest.raises(IndexError):
        AugmentedDraws(Augmentation(copies=1), broken, seed=0, count=2)
