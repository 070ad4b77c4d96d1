"""`manigraph train DIR` on a LeRobot dataset that `manigraph export` wrote.

The planner rebuilds each frame's scene and decision (``training.lerobot_source``), so the
training samples of the dataset are those of the log it came from, node for node, for the
paper's object/goal policy and the dishwasher's four heads alike; a policy trains from it. A
dataset of another robot, of another LeRobot layout or without a column is refused naming it.
"""

from __future__ import annotations

import io
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import torch

from manigraph_dishwasher.planner.expert import dishwasher_expert
from manigraph_dishwasher.training.loop import load_dish_demonstrations
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.gnn import GNNPolicy
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Scene
from manigraph_tools.interop.lerobot_export import export_lerobot
from manigraph_training.dataset import count_heads, load_demonstrations


@pytest.fixture(scope="module")
def demos(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """20 expert demonstrations (the paper's protocol) and their LeRobot export."""
    folder = tmp_path_factory.mktemp("demos")
    log = folder / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=20), log, progress=None)  # type: ignore[arg-type]
    export_lerobot(log, folder / "dataset", io.StringIO())
    return log, folder / "dataset"


def manigraph(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "manigraph_shared.cli", *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_the_dataset_trains_on_the_samples_of_its_log(demos: tuple[Path, Path]) -> None:
    log, dataset = demos
    from_log, from_dataset = load_demonstrations([log]), load_demonstrations([dataset])
    assert from_dataset.episodes == from_log.episodes == 20
    assert len(from_dataset.samples) == len(from_log.samples) > 20 * 4
    for a, b in zip(from_log.samples, from_dataset.samples, strict=True):
        assert torch.equal(a.x, b.x) and torch.equal(a.is_object, b.is_object)
        assert (a.object_index, a.goal_index) == (b.object_index, b.goal_index)
    assert count_heads([dataset]) == count_heads([log])


def test_dishwasher_decisions_round_trip_with_orientation_and_tray(tmp_path: Path) -> None:
    log = tmp_path / "dish.mcap"
    protocol = DemoProtocol(("dishwasher",), (4,), 2, 0, 4, "top-bottom")
    record_demos(dishwasher_expert("top-bottom"), protocol, log)
    export_lerobot(log, tmp_path / "dataset", io.StringIO())
    racks = {f.id for item in read_log(log, [Scene.key]) for f in item.decode().fixtures}  # type: ignore[attr-defined]
    assert racks == {"rack_top", "rack_bottom"}

    a, b = load_dish_demonstrations([log]), load_dish_demonstrations([tmp_path / "dataset"])

    assert len(a.samples) == len(b.samples) > 0
    assert {s.tray for s in b.samples} == {0, 1, 2}  # both toggles and placements
    for x, y in zip(a.samples, b.samples, strict=True):
        assert torch.equal(x.x, y.x)
        assert (x.num_objects, x.num_goals, x.object_index, x.goal_index) == (
            y.num_objects,
            y.num_goals,
            y.object_index,
            y.goal_index,
        )
        assert (x.orientation, x.tray) == (y.orientation, y.tray)


def test_manigraph_train_learns_a_policy_from_the_dataset(
    demos: tuple[Path, Path], tmp_path: Path
) -> None:
    _, dataset = demos
    checkpoint = tmp_path / "lerobot.pt"

    done = manigraph("train", str(dataset), "--epochs", "3", "--copies", "2", "-o", str(checkpoint))

    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads(done.stdout.strip().splitlines()[-1])
    assert summary["episodes"] == 20 and summary["demonstration_samples"] > 80
    policy = load_policy(str(checkpoint))
    assert isinstance(policy, GNNPolicy)
    scene = next(item.decode() for item in read_log(demos[0], [Scene.key]))
    assert isinstance(scene, Scene)
    decision = policy.decide(scene)
    assert decision is not None and decision.object_id in {o.id for o in scene.objects}


def _copy(dataset: Path, to: Path) -> Path:
    shutil.copytree(dataset, to)
    return to


def _edit_info(dataset: Path, **changes: object) -> None:
    path = dataset / "meta" / "info.json"
    info = json.loads(path.read_text())
    info.update(changes)
    path.write_text(json.dumps(info))


def test_a_dataset_missing_a_column_is_refused_naming_it(
    demos: tuple[Path, Path], tmp_path: Path
) -> None:
    dataset = _copy(demos[1], tmp_path / "dataset")
    info = json.loads((dataset / "meta" / "info.json").read_text())
    del info["features"]["observation.nodes.position"]
    _edit_info(dataset, features=info["features"])

    with pytest.raises(
        ConfigError, match=re.escape("column 'observation.nodes.position' is missing")
    ):
        load_demonstrations([dataset])
    done = manigraph("train", str(dataset), "--epochs", "1")
    assert done.returncode == CONFIG_EXIT_CODE
    assert "dataset: column 'observation.nodes.position' is missing" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_column_declared_but_absent_from_the_data_is_refused(
    demos: tuple[Path, Path], tmp_path: Path
) -> None:
    dataset = _copy(demos[1], tmp_path / "dataset")
    data = dataset / "data" / "chunk-000" / "file-000.parquet"
    table = pq.read_table(data)
    pq.write_table(table.drop_columns(["action"]), data)

    with pytest.raises(ConfigError, match="column 'action' is missing"):
        load_demonstrations([dataset])


def test_a_dataset_of_another_robot_is_refused(demos: tuple[Path, Path], tmp_path: Path) -> None:
    dataset = _copy(demos[1], tmp_path / "dataset")
    _edit_info(dataset, robot_type="so100")

    with pytest.raises(ConfigError, match="robot_type 'so100'") as refused:
        load_demonstrations([dataset])
    assert refused.value.field == "dataset"


def test_a_dataset_of_an_older_lerobot_layout_is_refused(
    demos: tuple[Path, Path], tmp_path: Path
) -> None:
    dataset = _copy(demos[1], tmp_path / "dataset")
    _edit_info(dataset, codebase_version="v2.1")

    with pytest.raises(ConfigError, match=re.escape("codebase_version 'v2.1'")):
        load_demonstrations([dataset])
