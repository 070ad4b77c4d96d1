"""Demonstrations from a LeRobot dataset written by ``manigraph export --format lerobot``.

A frame holds the scene a decision was made on as padded per-node columns and the decision as
node indices (docs/interop.md, "LeRobot datasets"; the exporter is
``manigraph_tools.interop.lerobot_layout``, the codes both use
:mod:`manigraph_shared.lerobot_codes`). :func:`read_lerobot` rebuilds each frame's ``Scene``
and ``Action``, so ``manigraph train DIR`` pairs and featurises them exactly as it does a log's.

A dataset of another robot, of another LeRobot format, or without a column this needs is
refused with a :class:`ConfigError` naming what is wrong.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq

from manigraph_shared.errors import ConfigError
from manigraph_shared.lerobot_codes import (
    FAMILY_ACTIONS,
    FIXTURE,
    FIXTURES,
    GOAL_ATTRIBUTES,
    NODE_CATEGORIES,
    NODES,
    ROBOT_TYPE,
)
from manigraph_shared.messages import (
    Action,
    GoalCategory,
    ObjectCategory,
    Quaternion,
    Scene,
    SceneFixture,
    SceneGoal,
    SceneObject,
    Vector3,
)

#: The columns a frame needs, with the dtype each must have.
REQUIRED_COLUMNS = {
    f"{NODES}.mask": "bool",
    f"{NODES}.category": "int64",
    f"{NODES}.position": "float64",
    f"{NODES}.orientation": "float64",
    f"{NODES}.size": "float64",
    f"{NODES}.filled": "bool",
    f"{NODES}.visible": "bool",
    f"{NODES}.open": "bool",
    f"{NODES}.rack": "int64",
    f"{NODES}.ids": "string",
    "observation.scene_sequence": "int64",
    "observation.stamp": "float64",
    "action": "int64",
    "episode_index": "int64",
    "frame_index": "int64",
}
#: Columns read where a dataset has them: a dataset written before each existed reads as none
#: (no attributes; fixtures as the ``rack`` code and ``open`` column say).
OPTIONAL_COLUMNS = (f"{NODES}.attributes", GOAL_ATTRIBUTES, FIXTURES)
#: The policy named on the rebuilt actions.
POLICY = "lerobot-dataset"


def read_info(root: Path) -> dict[str, Any]:
    """``meta/info.json``, checked: LeRobot v3, manigraph's robot, every column this reads."""
    try:
        info = json.loads((root / "meta" / "info.json").read_text())
    except (OSError, ValueError) as exc:
        raise ConfigError("dataset", f"cannot read {root}/meta/info.json: {exc}") from None
    if not isinstance(info, dict):
        raise ConfigError("dataset", "meta/info.json is not a JSON object")
    version = str(info.get("codebase_version", ""))
    if not version.startswith("v3."):
        raise ConfigError("dataset", f"codebase_version '{version}' is not LeRobot's v3 layout")
    if info.get("robot_type") != ROBOT_TYPE:
        raise ConfigError(
            "dataset",
            f"robot_type '{info.get('robot_type')}' is not manigraph's '{ROBOT_TYPE}' "
            "(a dataset of another robot has no scene graph to learn from)",
        )
    features = info.get("features")
    if not isinstance(features, dict):
        raise ConfigError("dataset", "meta/info.json has no features")
    for column, dtype in REQUIRED_COLUMNS.items():
        feature = features.get(column)
        if not isinstance(feature, dict):
            raise ConfigError("dataset", f"column '{column}' is missing")
        if feature.get("dtype") != dtype:
            raise ConfigError(
                "dataset", f"column '{column}' is {feature.get('dtype')}, not {dtype}"
            )
    return info


def read_lerobot(root: Path) -> Iterator[Scene | Action]:
    """Each frame's scene, then its decision, episode by episode in frame order."""
    read_info(root)
    paths = sorted((root / "data").glob("*/*.parquet"))
    if not paths:
        raise ConfigError("dataset", f"{root}/data holds no parquet file")
    episode_ids = _episode_ids(root)
    for path in paths:
        table = pq.read_table(path)
        for column in REQUIRED_COLUMNS:
            if column not in table.column_names:
                raise ConfigError("dataset", f"column '{column}' is missing from {path}")
        names = list(REQUIRED_COLUMNS) + [c for c in OPTIONAL_COLUMNS if c in table.column_names]
        for row in table.select(names).to_pylist():
            episode = episode_ids.get(row["episode_index"], f"lerobot-{row['episode_index']}")
            scene = frame_scene(row, episode)
            yield scene
            yield frame_action(row, scene, episode)


def _episode_ids(root: Path) -> dict[int, str]:
    """manigraph's own episode ids where the episode metadata keeps them."""
    ids: dict[int, str] = {}
    for path in sorted((root / "meta" / "episodes").glob("*/*.parquet")):
        table = pq.read_table(path)
        if "manigraph_episode_id" in table.column_names:
            for row in table.select(["episode_index", "manigraph_episode_id"]).to_pylist():
                ids[row["episode_index"]] = row["manigraph_episode_id"]
    return ids


def frame_scene(row: dict[str, Any], episode_id: str) -> Scene:
    """The scene of one frame: its real nodes (mask) back as objects, goals and fixtures."""
    ids = json.loads(row[f"{NODES}.ids"])
    count = sum(1 for valid in row[f"{NODES}.mask"] if valid)
    if len(ids) != count:
        raise ConfigError(
            "dataset", f"column '{NODES}.ids' names {len(ids)} nodes where the mask has {count}"
        )
    fixtures = {
        k: ids[k] for k in range(count) if ":" not in _category(row[f"{NODES}.category"][k])
    }
    # Datasets exported before a column existed lack it: none of what it holds then.
    attributes = _per_node(row, f"{NODES}.attributes", {}, count)
    goal_attributes = _per_node(row, GOAL_ATTRIBUTES, {}, count)
    described = _per_node(row, FIXTURES, None, count)
    objects, goals, scene_fixtures = [], [], []
    for k in range(count):
        kind, _, name = _category(row[f"{NODES}.category"][k]).partition(":")
        x, y, z = row[f"{NODES}.position"][k]
        position = Vector3(x=x, y=y, z=z)
        qx, qy, qz, qw = row[f"{NODES}.orientation"][k]
        orientation = Quaternion(x=qx, y=qy, z=qz, w=qw)
        filled, visible = row[f"{NODES}.filled"][k], row[f"{NODES}.visible"][k]
        if kind == "object":
            sx, sy, sz = row[f"{NODES}.size"][k]
            objects.append(
                SceneObject(
                    id=ids[k],
                    category=ObjectCategory(name),
                    position=position,
                    orientation=orientation,
                    size=Vector3(x=sx, y=sy, z=sz),
                    filled=filled,
                    visible=visible,
                    attributes=attributes[k],
                )
            )
        elif kind == "goal":
            fixture = row[f"{NODES}.rack"][k]
            goals.append(
                SceneGoal(
                    id=ids[k],
                    category=GoalCategory(name),
                    position=position,
                    orientation=orientation,
                    filled=filled,
                    visible=visible,
                    fixture=fixtures.get(fixture) if fixture >= 0 else None,
                    accepts=attributes[k],
                    attributes=goal_attributes[k],
                )
            )
        else:
            scene_fixtures.append(
                _fixture(ids[k], kind, position, orientation, described[k], row[f"{NODES}.open"][k])
            )
    return Scene(
        episode_id=episode_id,
        stamp=row["observation.stamp"],
        sequence=row["observation.scene_sequence"],
        objects=objects,
        goals=goals,
        fixtures=scene_fixtures,
    )


def _per_node(row: dict[str, Any], column: str, absent: Any, count: int) -> list[Any]:
    """``column``'s JSON list, one entry per node; ``absent`` for each where the dataset was
    written before the column existed."""
    values = json.loads(row.get(column) or "[]") or [absent] * count
    if len(values) != count:
        raise ConfigError(
            "dataset", f"column '{column}' names {len(values)} nodes where the mask has {count}"
        )
    return list(values)


def _fixture(
    node_id: str,
    category: str,
    position: Vector3,
    orientation: Quaternion,
    described: dict[str, Any] | None,
    open_: bool,
) -> SceneFixture:
    """A fixture node back: kind, state and size from the fixtures column; a dataset of
    contract v3 named its one kind by code and kept only its ``open`` flag."""
    if described is None:
        if category == FIXTURE:
            raise ConfigError("dataset", f"fixture '{node_id}' has no entry in '{FIXTURES}'")
        return SceneFixture(id=node_id, kind=category, position=position, state={"open": open_})
    size = described.get("size")
    return SceneFixture(
        id=node_id,
        kind=described["kind"],
        position=position,
        orientation=orientation,
        size=None if size is None else Vector3(x=size[0], y=size[1], z=size[2]),
        state=described.get("state") or {},
    )


def frame_action(row: dict[str, Any], scene: Scene, episode_id: str) -> Action:
    """The decision of one frame, naming its nodes by id (an index off the scene: an id no
    node has, so training skips it as it skips a log's)."""
    ids = json.loads(row[f"{NODES}.ids"])
    object_node, goal_node, orientation, family = row["action"]
    if not 0 <= family < len(FAMILY_ACTIONS):
        raise ConfigError(
            "dataset",
            f"column 'action': family action {family} is not in 0..{len(FAMILY_ACTIONS) - 1}",
        )

    def node_id(index: int) -> str:
        return ids[index] if 0 <= index < len(ids) else "not-in-scene"

    return Action(
        decision_id=f"{episode_id}:{row['frame_index']}",
        episode_id=episode_id,
        scene_sequence=scene.sequence,
        object_id=node_id(object_node),
        goal_id=node_id(goal_node),
        orientation_index=None if orientation < 0 else orientation,
        family_action=None if family == 0 else FAMILY_ACTIONS[family],
        policy=POLICY,
        stamp=scene.stamp,
    )


def _category(code: int) -> str:
    if not 0 <= code < len(NODE_CATEGORIES):
        raise ConfigError(
            "dataset",
            f"column '{NODES}.category': code {code} is not in 0..{len(NODE_CATEGORIES) - 1}",
        )
    return NODE_CATEGORIES[code]
