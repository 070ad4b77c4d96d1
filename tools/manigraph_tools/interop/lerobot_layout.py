"""The columns of a manigraph LeRobot dataset: names, dtypes, shapes, and the one meaning of
each, written by the exporter and documented in docs/interop.md.

One frame is one decision: the scene it was made on as padded per-node arrays (objects, then
goals, then fixtures, in the scene's order, ``max_nodes`` rows; rows past a frame's own node
count are padding, ``observation.nodes.mask`` false) and the decision as node indices. The
codes both the exporter and the planner's reader use (robot, categories, family actions) are
:mod:`manigraph_shared.lerobot_codes`; the round-trip test checks the columns against the
reader's.

Positions, orientations and sizes are float64 so a value read back is the value logged.
"""

from __future__ import annotations

import math
from typing import Any

from manigraph_shared.lerobot_codes import FIXTURES, GOAL_ATTRIBUTES, NODES, ROBOT_TYPE

#: The LeRobot dataset format written (``meta/info.json``'s ``codebase_version``).
CODEBASE_VERSION = "v3.0"
#: One frame per decision: a frame is a step of the episode, not a tick of a clock.
FPS = 1
CHUNKS_SIZE = 1000
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-000/file-000.parquet"

ACTION_NAMES = ["object_node", "goal_node", "orientation", "tray"]

IMAGES = "observation.images"


def node_features(max_nodes: int) -> dict[str, dict[str, Any]]:
    """The per-node columns for scenes of at most ``max_nodes`` nodes."""
    n = max_nodes

    def column(dtype: str, *axes: int, names: list[str]) -> dict[str, Any]:
        return {"dtype": dtype, "shape": [n, *axes], "names": names}

    return {
        f"{NODES}.mask": column("bool", names=["node"]),
        f"{NODES}.category": column("int64", names=["node"]),
        f"{NODES}.position": column("float64", 3, names=["node", "xyz"]),
        f"{NODES}.orientation": column("float64", 4, names=["node", "xyzw"]),
        f"{NODES}.size": column("float64", 3, names=["node", "xyz"]),
        f"{NODES}.filled": column("bool", names=["node"]),
        f"{NODES}.visible": column("bool", names=["node"]),
        f"{NODES}.open": column("bool", names=["node"]),
        f"{NODES}.rack": column("int64", names=["node"]),
        f"{NODES}.ids": {"dtype": "string", "shape": [1], "names": None},
        #: JSON: per node, an object's attributes or a goal's accepts ({} for neither).
        f"{NODES}.attributes": {"dtype": "string", "shape": [1], "names": None},
        #: JSON: per node, a goal's own attributes ({} for objects and fixtures).
        GOAL_ATTRIBUTES: {"dtype": "string", "shape": [1], "names": None},
        #: JSON: per node, a fixture's kind, state and size (null for objects and goals).
        FIXTURES: {"dtype": "string", "shape": [1], "names": None},
    }


def image_feature(height: int, width: int) -> dict[str, Any]:
    """A camera's column: encoded frames embedded in the parquet (LeRobot's ``image``)."""
    return {
        "dtype": "image",
        "shape": [height, width, 3],
        "names": ["height", "width", "channels"],
    }


def features(max_nodes: int, cameras: dict[str, tuple[int, int]]) -> dict[str, dict[str, Any]]:
    """Every column of the data files, in order (``cameras``: name -> (height, width))."""
    scalar = {"shape": [1], "names": None}
    return {
        **node_features(max_nodes),
        "observation.scene_sequence": {"dtype": "int64", **scalar},
        "observation.stamp": {"dtype": "float64", **scalar},
        **{f"{IMAGES}.{name}": image_feature(h, w) for name, (h, w) in sorted(cameras.items())},
        "action": {"dtype": "int64", "shape": [len(ACTION_NAMES)], "names": ACTION_NAMES},
        "timestamp": {"dtype": "float32", **scalar},
        "frame_index": {"dtype": "int64", **scalar},
        "episode_index": {"dtype": "int64", **scalar},
        "index": {"dtype": "int64", **scalar},
        "task_index": {"dtype": "int64", **scalar},
    }


def info(
    features_: dict[str, dict[str, Any]], episodes: int, frames: int, tasks: int
) -> dict[str, Any]:
    """``meta/info.json``."""
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": ROBOT_TYPE,
        "total_episodes": episodes,
        "total_frames": frames,
        "total_tasks": tasks,
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "fps": FPS,
        "splits": {"train": f"0:{episodes}"},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH,
        "features": features_,
    }


def column_stats(rows: list[Any]) -> dict[str, list[Any]] | None:
    """LeRobot's per-feature statistics (min, max, mean, std, count, quantiles), element by
    element over frames; None for columns that are not numbers (strings, images, flags)."""
    if not rows or isinstance(_first_leaf(rows[0]), bool | str | bytes | dict | type(None)):
        return None
    shape_of = rows[0] if isinstance(rows[0], list) else None
    flat = [_flatten(row) for row in rows]
    columns = list(zip(*flat, strict=True))
    stats: dict[str, list[float]] = {"min": [], "max": [], "mean": [], "std": []}
    quantiles = {"q01": 0.01, "q10": 0.10, "q50": 0.50, "q90": 0.90, "q99": 0.99}
    for name in quantiles:
        stats[name] = []
    for values in columns:
        ordered = sorted(float(v) for v in values)
        mean = math.fsum(ordered) / len(ordered)
        stats["min"].append(ordered[0])
        stats["max"].append(ordered[-1])
        stats["mean"].append(mean)
        stats["std"].append(math.sqrt(math.fsum((v - mean) ** 2 for v in ordered) / len(ordered)))
        for name, q in quantiles.items():
            stats[name].append(_quantile(ordered, q))
    shaped: dict[str, list[Any]] = {
        name: _reshape(values, shape_of) for name, values in stats.items()
    }
    shaped["count"] = [len(rows)]
    return shaped


def _first_leaf(value: Any) -> Any:
    while isinstance(value, list) and value:
        value = value[0]
    return value


def _flatten(value: Any) -> list[Any]:
    if not isinstance(value, list):
        return [value]
    return [leaf for item in value for leaf in _flatten(item)]


def _reshape(values: list[float], like: list[Any] | None) -> list[Any]:
    if like is None or not like or not isinstance(like[0], list):
        return values
    width = len(like[0])
    return [values[i : i + width] for i in range(0, len(values), width)]


def _quantile(ordered: list[float], q: float) -> float:
    """Linear interpolation between closest ranks (numpy's default)."""
    position = q * (len(ordered) - 1)
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)
