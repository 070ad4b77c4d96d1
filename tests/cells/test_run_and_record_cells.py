"""``manigraph run --cell`` drives one cell of a running stack; ``manigraph record`` keeps every
cell on its own channels, ``record --cell`` one cell only."""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

import pytest

from manigraph_shared.bus import Bus
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Scene
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

CELLS = ("cell-1", "cell-2")


def run_in(stack: Stack, cell: str, seed: int) -> set[str]:
    """One episode in ``cell`` by ``manigraph run --cell``; its episode ids."""
    result = stack.run(
        "run", "--cell", cell, "--blocks", "3", "--episodes", "1", "--seed", str(seed), "--json"
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads(result.stdout.splitlines()[-1])
    assert summary["success_rate"] == 1.0, summary
    return {r["episode_id"] for r in summary["results"]}


def scenes_by_topic(path: Path) -> dict[str, set[str]]:
    """Each scene channel's topic -> the episodes of its scenes (checking each message's
    schema and the cell its topic names)."""
    found: dict[str, set[str]] = defaultdict(set)
    for logged in read_log(path, topics=["manigraph/**/world/scene"]):
        assert logged.schema == Scene.type_name(), logged.topic
        scene = logged.decode()
        assert isinstance(scene, Scene)
        found[logged.topic].add(scene.episode_id)
    return dict(found)


def test_run_drives_one_cell_and_the_log_says_which_cell_each_scene_is_from(
    running_stack: Stack, tmp_path: Path
) -> None:
    stack = running_stack
    every, only_first = tmp_path / "every.mcap", tmp_path / "cell-1.mcap"
    stack.start("router")
    stack.start("recorder", "record", "--output", str(every))
    stack.start("recorder@cell-1", "record", "--output", str(only_first), "--cell", "cell-1")
    for cell in CELLS:
        stack.start(f"sim@{cell}", "sim", "--cell", cell)
        stack.start(f"skills@{cell}", "skills", "--cell", cell)
    stack.start("planner", "planner", "--cells", ",".join(CELLS))
    config = stack.bus_config()
    with Bus.open(config) as default, Bus.open(replace(config, cell="cell-1")) as first:
        stack.wait_alive(default, "recorder")
        stack.wait_alive(first, "recorder")
    episodes = {cell: run_in(stack, cell, seed) for seed, cell in enumerate(CELLS)}
    assert episodes["cell-1"].isdisjoint(episodes["cell-2"])
    assert stack.stop("recorder") == 0 and stack.stop("recorder@cell-1") == 0

    recorded = scenes_by_topic(every)
    assert set(recorded) == {"manigraph/cell-1/world/scene", "manigraph/cell-2/world/scene"}
    for cell in CELLS:  # each cell's channel holds that cell's episodes and no other's
        assert recorded[f"manigraph/{cell}/world/scene"] == episodes[cell]
    assert scenes_by_topic(only_first) == {"manigraph/cell-1/world/scene": episodes["cell-1"]}

    topics = {logged.topic for logged in read_log(every)}
    assert {"/cell-1/foxglove/scene", "/cell-2/foxglove/scene"} <= topics  # drawn apart
    assert "/foxglove/scene" not in topics  # nothing ran in the default cell
