"""In-process evaluation and the full Zenoh stack take the same decisions for the same seed."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_blocks.training.augment import Augmentation
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.episode_loop import run_episode
from manigraph_planner.gnn import save_checkpoint
from manigraph_planner.policies import load_policy
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, EpisodeEvent, EpisodeRequest
from manigraph_testkit.testing import run_up
from manigraph_training.dataset import load_demonstrations
from manigraph_training.trainer import TrainConfig, train

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def rough_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A barely trained GNN: it makes mistakes, so parity covers failed actions too."""
    folder = tmp_path_factory.mktemp("parity")
    demos_path = folder / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=4), demos_path, progress=None)  # type: ignore[arg-type]
    demos = load_demonstrations([demos_path])
    config = TrainConfig(architecture="gcn", seed=1, epochs=3, augmentation=Augmentation(copies=1))
    net, metrics = train(demos, config, progress=None)
    return save_checkpoint(
        folder / "rough.pt",
        net,
        training_config=config.to_dict(),
        data_hash=demos.data_hash,
        metrics=metrics,
    )


@pytest.mark.parametrize("policy", ["expert", "rough"])
def test_same_seed_same_actions_in_process_and_over_zenoh(
    policy: str, rough_policy: Path, tmp_path: Path
) -> None:
    spec = str(rough_policy) if policy == "rough" else "expert"
    log = tmp_path / "stack.mcap"
    run_up(
        "--policy",
        spec,
        "--task",
        "stack",
        "--blocks",
        "4",
        "--episodes",
        "3",
        "--seed",
        "11",
        "--record",
        str(log),
        timeout=180,
    )

    over_zenoh: dict[int, list[tuple[str, str]]] = {}
    seeds: dict[str, int] = {}
    outcome: dict[int, tuple[bool, int]] = {}
    for item in read_log(log, [EpisodeEvent.key, Action.key]):
        message = item.decode()
        if isinstance(message, EpisodeEvent):
            seeds[message.episode_id] = message.seed
            if message.phase == "end":
                outcome[message.seed] = (bool(message.success), message.steps)
    for item in read_log(log, [Action.key]):
        action = Action.decode(item.data)
        over_zenoh.setdefault(seeds[action.episode_id], []).append(
            (action.object_id, action.goal_id)
        )

    loaded = load_policy(spec)
    for seed in (11, 12, 13):
        record = run_episode(
            loaded, EpisodeRequest(episode_id=f"p{seed}", task="stack", blocks=4, seed=seed)
        )
        in_process = [(s.action.object_id, s.action.goal_id) for s in record.steps]
        assert over_zenoh.get(seed, []) == in_process, f"seed {seed}"
        assert outcome[seed] == (record.success, record.end.steps), f"seed {seed}"
