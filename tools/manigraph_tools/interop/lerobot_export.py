"""``manigraph export LOG.mcap --format lerobot -o DIR``: demonstrations as a LeRobot dataset.

Every decision of the log (an ``Action`` paired with the ``Scene`` it names, as
``manigraph train`` pairs them) becomes one frame of its episode: the scene as per-node columns
and the decision as node indices (:mod:`~manigraph_tools.interop.lerobot_layout`), plus each
camera's latest frame where the log holds camera images. The node features the policy sees are
built by the planner, which tools cannot import; the raw per-node values are written instead,
from which ``manigraph train DIR`` rebuilds the very same scenes.

The folder follows LeRobot's v3 layout::

    meta/info.json  meta/stats.json  meta/tasks.parquet
    meta/episodes/chunk-000/file-000.parquet  data/chunk-000/file-000.parquet

A log cut short by a killed writer exports every decision up to its last complete chunk; the
summary's ``truncated`` says where, and ``partial_episodes`` names episodes without an end.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from manigraph_shared import lerobot_codes as codes
from manigraph_shared.errors import ConfigError, LogError
from manigraph_shared.messages import (
    Action,
    CompressedImage,
    EpisodeEvent,
    EpisodePhase,
    Scene,
    SceneFixture,
    SceneGoal,
)
from manigraph_tools.interop import lerobot_layout as layout
from manigraph_tools.interop.lerobot_frames import LatestFrames
from manigraph_tools.interop.source import SourceLog, check_paths, choose_cell

try:  # the `lerobot` extra: the service images install the tools without it
    import pyarrow as pa
    import pyarrow.parquet as pq
except ImportError as missing:
    raise ConfigError(
        "format",
        "a LeRobot export needs pyarrow, which this install lacks "
        "(pip install 'manigraph-tools[lerobot]')",
    ) from missing

#: A task name for episodes whose start event is not in the log.
UNKNOWN_TASK = "unknown"


@dataclass
class Step:
    scene: Scene
    action: Action
    frames: dict[str, bytes]


@dataclass
class Episode:
    episode_id: str
    task: str = UNKNOWN_TASK
    steps: list[Step] = field(default_factory=list)
    success: bool | None = None
    ended: bool = False


def export_lerobot(
    log: Path, out: Path, progress: TextIO, cell: str | None = None
) -> dict[str, object]:
    """Write the decisions of ``log``'s robot cell ``cell`` (:func:`choose_cell`) as a LeRobot
    v3 dataset in ``out``; return a summary."""
    check_paths(log, out)
    source = SourceLog(log, choose_cell(log, cell))
    episodes, skipped, frames = _read_episodes(source)
    exported = [episode for episode in episodes if episode.steps]
    if not exported:
        raise LogError(
            f"{log}: no decision could be paired with the scene it was decided on: "
            "nothing to export"
        )
    tasks = sorted({episode.task for episode in exported})
    max_nodes = max(_node_count(step.scene) for episode in exported for step in episode.steps)
    features = layout.features(max_nodes, frames.sizes)
    rows = _rows(exported, tasks, max_nodes, sorted(frames.sizes))
    data = _table(rows, features)
    out.mkdir(parents=True, exist_ok=True)
    data_path = out / layout.DATA_PATH.format(chunk_index=0, file_index=0)
    data_path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(data, data_path)
    _write_episodes(out, exported, tasks)
    _write_tasks(out, tasks)
    total = data.num_rows
    _write_json(out / "meta" / "info.json", layout.info(features, len(exported), total, len(tasks)))
    _write_json(out / "meta" / "stats.json", _stats(rows))
    truncated = source.stopped()
    partial = [episode.episode_id for episode in exported if not episode.ended]
    if truncated is not None:
        last = exported[-1]
        truncated["last_exported"] = {
            "episode_id": last.episode_id,
            "frame_index": len(last.steps) - 1,
            "decision_id": last.steps[-1].action.decision_id,
        }
        progress.write(
            f"lerobot: {log} is truncated; exported up to {last.steps[-1].action.decision_id} "
            f"(log time {truncated['last_log_time_ns']} ns)\n"
        )
    progress.write(f"lerobot: {len(exported)} episodes, {total} frames -> {out}\n")
    return {
        "format": "lerobot",
        "cell": source.cell,
        "output": str(out),
        "codebase_version": layout.CODEBASE_VERSION,
        "episodes": len(exported),
        "frames": total,
        "tasks": tasks,
        "max_nodes": max_nodes,
        "cameras": sorted(frames.sizes),
        "skipped_actions": skipped,
        "partial_episodes": partial,
        "truncated": truncated,
    }


def _read_episodes(source: SourceLog) -> tuple[list[Episode], int, LatestFrames]:
    """Episodes in order of first appearance, unpaired actions counted, cameras seen."""
    episodes: dict[str, Episode] = {}
    scenes: dict[tuple[str, int], Scene] = {}
    frames = LatestFrames()
    skipped = 0
    wanted = (Scene, Action, EpisodeEvent, CompressedImage)
    for _item, message in source.messages(wanted):
        if isinstance(message, CompressedImage):
            frames.see(message)
        elif isinstance(message, Scene):
            scenes[(message.episode_id, message.sequence)] = message
        elif isinstance(message, EpisodeEvent):
            episode = episodes.setdefault(message.episode_id, Episode(message.episode_id))
            if message.phase is EpisodePhase.START or episode.task == UNKNOWN_TASK:
                episode.task = message.task
            if message.phase is EpisodePhase.END:
                episode.ended, episode.success = True, message.success
                # Its scenes are no longer needed: a long recorded run stays bounded.
                for key in [k for k in scenes if k[0] == message.episode_id]:
                    del scenes[key]
        elif isinstance(message, Action):
            scene = scenes.get((message.episode_id, message.scene_sequence))
            if scene is None:
                skipped += 1
                continue
            episode = episodes.setdefault(message.episode_id, Episode(message.episode_id))
            episode.steps.append(Step(scene, message, frames.snapshot()))
    return list(episodes.values()), skipped, frames


def _node_count(scene: Scene) -> int:
    return len(scene.objects) + len(scene.goals) + len(scene.fixtures)


def scene_nodes(scene: Scene, max_nodes: int) -> dict[str, Any]:
    """The per-node columns of one scene, padded to ``max_nodes`` rows."""
    fixtures = {
        fixture.id: len(scene.objects) + len(scene.goals) + i
        for i, fixture in enumerate(scene.fixtures)
    }
    columns: dict[str, list[Any]] = {
        name: [] for name in ("mask", "category", "position", "orientation", "size")
    }
    columns.update({name: [] for name in ("filled", "visible", "open", "rack")})
    ids: list[str] = []
    attributes: list[dict[str, Any]] = []
    described: list[dict[str, Any] | None] = []
    goal_attributes: list[dict[str, Any]] = []

    def node(
        category: str,
        entity: Any,
        size: list[float],
        filled: bool,
        visible: bool,
        open_: bool = False,
    ) -> None:
        q = getattr(entity, "orientation", None)
        columns["mask"].append(True)
        columns["category"].append(codes.NODE_CATEGORIES.index(category))
        columns["position"].append(list(entity.position.as_tuple()))
        columns["orientation"].append([q.x, q.y, q.z, q.w] if q else [0.0, 0.0, 0.0, 1.0])
        columns["size"].append(size)
        columns["filled"].append(filled)
        columns["visible"].append(visible)
        columns["open"].append(open_)
        fixture = getattr(entity, "fixture", None)
        columns["rack"].append(fixtures.get(fixture, -1) if fixture is not None else -1)
        ids.append(entity.id)
        if isinstance(entity, SceneGoal):  # what it accepts; its own attributes apart
            attributes.append(dict(entity.accepts))
            goal_attributes.append(dict(entity.attributes))
        else:
            attributes.append(dict(getattr(entity, "attributes", {})))
            goal_attributes.append({})
        described.append(_fixture_columns(entity) if isinstance(entity, SceneFixture) else None)

    for obj in scene.objects:
        node(
            f"object:{obj.category.value}", obj, list(obj.size.as_tuple()), obj.filled, obj.visible
        )
    for goal in scene.goals:
        node(f"goal:{goal.category.value}", goal, [0.0] * 3, goal.filled, goal.visible)
    for item in scene.fixtures:  # any kind: named in the fixtures column, not by a code
        size = list(item.size.as_tuple()) if item.size else [0.0] * 3
        node(codes.FIXTURE, item, size, False, True, bool(item.state.get("open", False)))
    padding = max_nodes - len(ids)
    pads: dict[str, Any] = {"mask": False, "category": -1, "position": [0.0] * 3}
    pads.update({"orientation": [0.0] * 4, "size": [0.0] * 3, "filled": False})
    pads.update({"visible": False, "open": False, "rack": -1})
    row: dict[str, Any] = {
        f"{codes.NODES}.{name}": values + [pads[name]] * padding for name, values in columns.items()
    }
    row[f"{codes.NODES}.ids"] = json.dumps(ids)
    row[f"{codes.NODES}.attributes"] = json.dumps(attributes)
    row[codes.GOAL_ATTRIBUTES] = json.dumps(goal_attributes)
    row[codes.FIXTURES] = json.dumps(described)
    return row


def _fixture_columns(fixture: SceneFixture) -> dict[str, Any]:
    """What the fixtures column keeps of ``fixture``: all a reader needs to rebuild it."""
    size = list(fixture.size.as_tuple()) if fixture.size else None
    return {"kind": fixture.kind, "state": dict(fixture.state), "size": size}


def decision(action: Action, ids: list[str]) -> list[int]:
    """``action``: object node, goal node, orientation (-1: none), family action index."""

    def index(node_id: str) -> int:
        return ids.index(node_id) if node_id in ids else -1

    orientation = -1 if action.orientation_index is None else action.orientation_index
    family = codes.FAMILY_ACTIONS.index(action.family_action or "none")
    return [index(action.object_id), index(action.goal_id), orientation, family]


def _rows(
    episodes: list[Episode], tasks: list[str], max_nodes: int, cameras: list[str]
) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for episode_index, episode in enumerate(episodes):
        for frame_index, step in enumerate(episode.steps):
            row = scene_nodes(step.scene, max_nodes)
            ids = json.loads(row[f"{codes.NODES}.ids"])
            row["observation.scene_sequence"] = step.scene.sequence
            row["observation.stamp"] = step.scene.stamp
            for camera in cameras:
                data = step.frames.get(camera)
                image = None if data is None else {"bytes": data, "path": None}
                row[f"{layout.IMAGES}.{camera}"] = image
            row["action"] = decision(step.action, ids)
            row["timestamp"] = frame_index / layout.FPS
            row["frame_index"] = frame_index
            row["episode_index"] = episode_index
            row["index"] = len(rows)
            row["task_index"] = tasks.index(episode.task)
            rows.append(row)
    return rows


_SCALARS = {
    "bool": pa.bool_(),
    "int64": pa.int64(),
    "float64": pa.float64(),
    "float32": pa.float32(),
    "string": pa.string(),
}
_IMAGE = pa.struct([("bytes", pa.binary()), ("path", pa.string())])


def arrow_type(feature: dict[str, Any]) -> pa.DataType:
    """The parquet type the ``datasets`` library reads a LeRobot feature as: a value, a fixed
    length list for one axis, nested lists for two (``Array2D``), a struct for an image."""
    if feature["dtype"] == "image":
        return _IMAGE
    value = _SCALARS[feature["dtype"]]
    shape = feature["shape"]
    if shape == [1]:
        return value
    if len(shape) == 1:
        return pa.list_(value, shape[0])
    return pa.list_(pa.list_(value))


def _table(rows: list[dict[str, Any]], features: dict[str, dict[str, Any]]) -> pa.Table:
    fields = [pa.field(name, arrow_type(feature)) for name, feature in features.items()]
    schema = pa.schema(fields)
    arrays = [
        pa.array([row[name] for row in rows], type=schema.field(name).type) for name in features
    ]
    return pa.Table.from_arrays(arrays, schema=schema)


def _write_episodes(out: Path, episodes: list[Episode], tasks: list[str]) -> None:
    """``meta/episodes``: where each episode's frames are, and manigraph's own episode id."""
    starts, start = [], 0
    for episode in episodes:
        starts.append(start)
        start += len(episode.steps)
    count = len(episodes)
    table = pa.table(
        {
            "episode_index": pa.array(range(count), pa.int64()),
            "tasks": pa.array([[episode.task] for episode in episodes], pa.list_(pa.string())),
            "length": pa.array([len(episode.steps) for episode in episodes], pa.int64()),
            "data/chunk_index": pa.array([0] * count, pa.int64()),
            "data/file_index": pa.array([0] * count, pa.int64()),
            "dataset_from_index": pa.array(starts, pa.int64()),
            "dataset_to_index": pa.array(
                [s + len(e.steps) for s, e in zip(starts, episodes, strict=True)], pa.int64()
            ),
            "meta/episodes/chunk_index": pa.array([0] * count, pa.int64()),
            "meta/episodes/file_index": pa.array([0] * count, pa.int64()),
            "manigraph_episode_id": pa.array([e.episode_id for e in episodes], pa.string()),
            "success": pa.array([e.success for e in episodes], pa.bool_()),
        }
    )
    path = out / layout.EPISODES_PATH
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path)


def _write_tasks(out: Path, tasks: list[str]) -> None:
    """``meta/tasks.parquet``: LeRobot reads it with pandas, the task text as the index; the
    pandas metadata says so without pandas being needed here."""
    pandas_meta = {
        "index_columns": ["task"],
        "column_indexes": [],
        "columns": [
            {"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
             "numpy_type": "int64", "metadata": None},
            {"name": "task", "field_name": "task", "pandas_type": "unicode",
             "numpy_type": "object", "metadata": None},
        ],
        "creator": {"library": "manigraph"},
    }  # fmt: skip
    table = pa.table(
        {"task_index": pa.array(range(len(tasks)), pa.int64()), "task": pa.array(tasks)}
    ).replace_schema_metadata({"pandas": json.dumps(pandas_meta)})
    pq.write_table(table, out / "meta" / "tasks.parquet")


def _stats(rows: list[dict[str, Any]]) -> dict[str, Any]:
    stats = {}
    for name in rows[0]:
        column = layout.column_stats([row[name] for row in rows])
        if column is not None:
            stats[name] = column
    return stats


def _write_json(path: Path, value: object) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(value, indent=2) + "\n")
