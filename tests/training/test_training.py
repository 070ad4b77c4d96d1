"""Imitation learning end to end on a small real demonstration log."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from manigraph_blocks.training.augment import Augmentation
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_planner.gnn import load_checkpoint, save_checkpoint
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import LogError
from manigraph_shared.mcap_log import McapLogWriter
from manigraph_shared.messages import Action
from manigraph_training.dataset import load_demonstrations
from manigraph_training.trainer import TrainConfig, train


@pytest.fixture(scope="module")
def demo_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("demos") / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=8), path, progress=None)  # type: ignore[arg-type]
    return path


def test_demos_pair_every_action_with_its_scene(demo_log: Path) -> None:
    demos = load_demonstrations([demo_log])
    assert demos.episodes == 8
    assert demos.skipped == 0
    assert len(demos.samples) >= 8 * 5  # open, >= 3 blocks, close
    sample = demos.samples[0]
    assert bool(sample.is_object[sample.object_index])
    assert not bool(sample.is_object[sample.goal_index])
    assert load_demonstrations([demo_log]).data_hash == demos.data_hash


def test_a_log_without_decisions_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "empty.mcap"
    McapLogWriter(path).close()
    with pytest.raises(LogError, match="no action"):
        load_demonstrations([path])


def test_augmentation_keeps_labels_and_moves_scenes_rigidly(demo_log: Path) -> None:
    demos = load_demonstrations([demo_log])
    augmentation = Augmentation(copies=2, noise=0.0, noise_xy=0.0).without_structure()
    out = augmentation.apply(demos.samples[:3], torch.Generator().manual_seed(0))
    assert len(out) == 9
    original, copy = out[0], out[3]
    assert copy.object_index == original.object_index and copy.goal_index == original.goal_index
    shift = copy.x[:, 1:4] - original.x[:, 1:4]
    assert torch.allclose(shift, shift[0].expand_as(shift), atol=1e-6)  # one rigid translation
    assert torch.equal(copy.x[:, [0, 4]], original.x[:, [0, 4]])  # category and filled untouched


@pytest.mark.slow
def test_a_trained_policy_imitates_the_expert_and_generalizes_to_stacking(
    demo_log: Path, tmp_path: Path
) -> None:
    demos = load_demonstrations([demo_log])
    config = TrainConfig(
        architecture="sage", seed=0, epochs=150, augmentation=Augmentation(copies=3)
    )
    net, metrics = train(demos, config, progress=None)
    assert metrics["demo_accuracy"] >= 0.8  # type: ignore[operator]
    path = save_checkpoint(
        tmp_path / "sage.pt",
        net,
        training_config=config.to_dict(),
        data_hash=demos.data_hash,
        metrics=metrics,
    )
    _, info = load_checkpoint(path)
    assert info.data_hash == demos.data_hash
    policy = load_policy(str(path))
    assert isinstance(policy, GNNPolicy)
    summary = evaluate(policy, EvalSpec("stack", blocks=5, episodes=10, seed=100), progress=None)
    assert summary["success_rate"] >= 0.9


def test_training_is_seeded(demo_log: Path) -> None:
    demos = load_demonstrations([demo_log])
    config = TrainConfig(architecture="gcn", seed=3, epochs=2, augmentation=Augmentation(copies=1))
    a, _ = train(demos, config, progress=None)
    b, _ = train(demos, config, progress=None)
    for (name, p), (_, q) in zip(a.state_dict().items(), b.state_dict().items(), strict=True):
        assert torch.equal(p, q), name


def test_bad_training_values_name_the_field() -> None:
    with pytest.raises(ValueError, match="epochs"):
        TrainConfig(epochs=-1)
    with pytest.raises(ValueError, match="translate_z"):
        Augmentation(translate_z=-1.0)


def test_action_for_an_invisible_node_is_skipped(tmp_path: Path, demo_log: Path) -> None:
    path = tmp_path / "bad.mcap"
    log = McapLogWriter(path)
    for n, item in enumerate(
        __import__("manigraph_shared.mcap_log", fromlist=["read_log"]).read_log(demo_log)
    ):
        data = item.data
        if item.topic == Action.key and n < 10:
            data = Action.decode(data).replace(object_id="ghost").encode()
        log.write(item.topic, data, item.log_time_ns)
    log.close()
    demos = load_demonstrations([path])
    assert demos.skipped >= 1


def test_training_flushes_denormals_only_while_it_runs(demo_log: Path) -> None:
    denormal = torch.tensor([1e-40])  # below float32's smallest normal, 1.2e-38
    seen: list[float] = []
    demos = load_demonstrations([demo_log])
    config = TrainConfig(architecture="gcn", epochs=1, augmentation=Augmentation(copies=0))
    train(demos, config, on_epoch=lambda *_: seen.append(float(denormal * 1.0)))
    assert seen and all(value == 0.0 for value in seen)  # flushed: the slow path is never taken
    assert float(denormal * 1.0) > 0.0  # and the caller's float behaviour is back
