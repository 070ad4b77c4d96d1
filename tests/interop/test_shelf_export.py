"""A shelf log exports to LeRobot and to a ROS 2 bag with its cupboard: fixtures of kinds no
code of the exporters names (``board``, ``wall``) keep their kind, size and state, and the
dataset trains exactly as the log does (a slot's row, a goal attribute, included)."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
import torch
from lerobot_helpers import lerobot_python, load_with_lerobot

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_shared import lerobot_codes as codes
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Scene
from manigraph_tools.interop.lerobot_export import export_lerobot
from manigraph_tools.interop.ros2_bag import export_ros2
from manigraph_tools.interop.ros2_messages import SCENE_MARKERS_TOPIC
from manigraph_training.dataset import load_demonstrations
from manigraph_training.lerobot_source import read_lerobot


@pytest.fixture(scope="module")
def shelf_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two episodes of the shelf's expert, four blocks (seeds 53940, 53941)."""
    log = tmp_path_factory.mktemp("shelf") / "shelf.mcap"
    protocol = DemoProtocol(tasks=("shelf",), trajectories=2, seed=53940, objects=4)
    record_demos(None, protocol, log)
    return log


def _scenes(log: Path) -> list[Scene]:
    scenes = [item.decode() for item in read_log(log, [Scene.key])]
    assert all(isinstance(scene, Scene) for scene in scenes)
    return scenes


@pytest.mark.timeout(1800)  # building lerobot's venv the first time downloads torch
def test_a_shelf_log_exports_to_lerobot_and_reads_back_with_its_cupboard(
    shelf_log: Path, tmp_path: Path
) -> None:
    logged = {(s.episode_id, s.sequence): s for s in _scenes(shelf_log)}
    assert {f.kind for s in logged.values() for f in s.fixtures} == {"board", "wall"}
    dataset = tmp_path / "dataset"
    summary = export_lerobot(shelf_log, dataset, io.StringIO())
    assert summary["episodes"] == 2 and summary["frames"] == 8

    table = pq.read_table(dataset / "data" / "chunk-000" / "file-000.parquet")
    categories = table.column(f"{codes.NODES}.category").to_pylist()[0]
    fixture_code = codes.NODE_CATEGORIES.index(codes.FIXTURE)
    first = logged[next(iter(logged))]
    assert categories.count(fixture_code) == len(first.fixtures) == 5  # 2 boards, 3 walls

    read = [m for m in read_lerobot(dataset) if isinstance(m, Scene)]
    assert len(read) == 8
    for scene in read:
        source = logged[(scene.episode_id, scene.sequence)]
        assert scene.fixtures == source.fixtures  # kind, position, size and state, as logged
        assert [g.attributes for g in scene.goals] == [g.attributes for g in source.goals]
        assert [g.accepts for g in scene.goals] == [g.accepts for g in source.goals]

    got = load_with_lerobot(lerobot_python(), dataset, tmp_path)  # LeRobot's own loader
    assert got["len"] == 8 and codes.FIXTURES in got["features"]  # type: ignore[operator]
    frame = got["frames"][0]  # type: ignore[index]
    kinds = [d["kind"] for d in json.loads(frame[codes.FIXTURES]) if d is not None]
    assert kinds == [f.kind for f in first.fixtures]

    from_log, from_dataset = load_demonstrations([shelf_log]), load_demonstrations([dataset])
    assert len(from_log.samples) == len(from_dataset.samples) == 8
    for a, b in zip(from_log.samples, from_dataset.samples, strict=True):
        assert torch.equal(a.x, b.x)
        assert (a.object_index, a.goal_index) == (b.object_index, b.goal_index)


def test_a_shelf_log_exports_to_a_ros2_bag_with_a_marker_per_fixture(
    shelf_log: Path, tmp_path: Path
) -> None:
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    summary = export_ros2(shelf_log, tmp_path / "bag", io.StringIO())
    assert summary["invalid"] == {}
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(tmp_path / "bag") as reader:
        marker_arrays: list[Any] = [
            store.deserialize_cdr(data, connection.msgtype)
            for connection, _, data in reader.messages()
            if connection.topic == SCENE_MARKERS_TOPIC
        ]
    scenes = _scenes(shelf_log)
    assert len(marker_arrays) == len(scenes) > 0
    for markers, scene in zip(marker_arrays, scenes, strict=True):
        drawn = {m.text.split(" ")[0]: m for m in markers.markers if m.ns == "fixtures"}
        assert drawn.keys() == {f.id for f in scene.fixtures}
        for fixture in scene.fixtures:
            marker = drawn[fixture.id]
            assert fixture.size is not None
            assert (marker.scale.x, marker.scale.y, marker.scale.z) == fixture.size.as_tuple()
            assert marker.pose.position.z == fixture.position.z
            assert f"kind {fixture.kind}" in marker.text
