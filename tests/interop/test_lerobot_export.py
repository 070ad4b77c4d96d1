"""`manigraph export --format lerobot` read back by LeRobot's own ``LeRobotDataset``.

20 expert demonstrations (``manigraph demos``' protocol) are exported and loaded by lerobot in
its own venv (``lerobot_helpers``): lengths, episode boundaries and every step's values must be
those of the log. Frames of a recorded camera come back pixel for pixel; a truncated log
exports what it can and says where it stopped.
"""

from __future__ import annotations

import io
import json
import struct
from pathlib import Path
from typing import Any

import pytest
from lerobot_helpers import lerobot_python, load_with_lerobot
from PIL import Image

from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.policies import load_policy
from manigraph_shared import lerobot_codes as codes
from manigraph_shared.errors import LogError
from manigraph_shared.mcap_log import McapLogWriter, read_log
from manigraph_shared.messages import Action, CompressedImage, EpisodeEvent, Scene
from manigraph_tools.interop.lerobot_export import export_lerobot

Step = tuple[Scene, Action]


@pytest.fixture(scope="module")
def demo_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("demos") / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=20), path, progress=None)  # type: ignore[arg-type]
    return path


@pytest.fixture(scope="module")
def lerobot() -> Path:
    return lerobot_python()


def source_episodes(log: Path) -> list[tuple[str, str, list[Step]]]:
    """(episode id, task, decisions paired with their scenes) in log order, read with
    manigraph's own MCAP reader."""
    scenes: dict[tuple[str, int], Scene] = {}
    tasks: dict[str, str] = {}
    steps: dict[str, list[Step]] = {}
    for item in read_log(log, [Scene.key, Action.key, EpisodeEvent.key]):
        message = item.decode()
        if isinstance(message, EpisodeEvent):
            tasks.setdefault(message.episode_id, message.task)
        elif isinstance(message, Scene):
            scenes[(message.episode_id, message.sequence)] = message
        elif isinstance(message, Action):
            scene = scenes.get((message.episode_id, message.scene_sequence))
            if scene is not None:
                steps.setdefault(message.episode_id, []).append((scene, message))
    return [(episode, tasks.get(episode, "unknown"), s) for episode, s in steps.items()]


def f32(value: float) -> float:
    """``value`` as LeRobot hands it to a policy (a float32 tensor)."""
    return float(struct.unpack("f", struct.pack("f", value))[0])


def expected_nodes(scene: Scene) -> dict[str, list[Any]]:
    nodes: list[Any] = [*scene.objects, *scene.goals, *scene.fixtures]
    categories = [f"object:{o.category.value}" for o in scene.objects]
    categories += [f"goal:{g.category.value}" for g in scene.goals]
    categories += [codes.FIXTURE for _ in scene.fixtures]  # its kind in the fixtures column
    return {
        "ids": [node.id for node in nodes],
        "category": [codes.NODE_CATEGORIES.index(c) for c in categories],
        "position": [list(node.position.as_tuple()) for node in nodes],
        "filled": [bool(getattr(node, "filled", False)) for node in nodes],
        "visible": [bool(getattr(node, "visible", True)) for node in nodes],
    }


#: Building lerobot's venv the first time downloads torch (minutes); later runs reuse it.
VENV_BUILD_TIMEOUT = pytest.mark.timeout(1800)


@VENV_BUILD_TIMEOUT
def test_lerobot_reads_every_step_of_20_demonstrations_back(
    demo_log: Path, lerobot: Path, tmp_path: Path
) -> None:
    progress = io.StringIO()
    summary = export_lerobot(demo_log, tmp_path / "dataset", progress)
    episodes = source_episodes(demo_log)
    steps = [step for _, _, s in episodes for step in s]
    assert summary["episodes"] == len(episodes) == 20
    assert summary["frames"] == len(steps)
    assert summary["truncated"] is None

    got = load_with_lerobot(lerobot, tmp_path / "dataset", tmp_path)

    assert got["len"] == len(steps) and got["num_episodes"] == 20
    start = 0
    for index, (episode_id, task, episode_steps) in enumerate(episodes):
        meta = got["episodes"][index]  # type: ignore[index]
        assert meta["manigraph_episode_id"] == episode_id and meta["tasks"] == [task]
        assert meta["length"] == len(episode_steps)
        assert (meta["dataset_from_index"], meta["dataset_to_index"]) == (
            start,
            start + len(episode_steps),
        )
        start += len(episode_steps)
    assert {"action", "observation.nodes.position"} <= set(got["stats_keys"])  # type: ignore[arg-type]
    frames: list[dict[str, Any]] = got["frames"]  # type: ignore[assignment]
    raw: dict[str, list[Any]] = got["raw"]  # type: ignore[assignment]
    positions = 0
    for i, (frame, (scene, action)) in enumerate(zip(frames, steps, strict=True)):
        want = expected_nodes(scene)
        n = len(want["ids"])
        assert json.loads(frame["observation.nodes.ids"]) == want["ids"]
        assert frame["observation.nodes.mask"] == [True] * n + [False] * (
            len(frame["observation.nodes.mask"]) - n
        )
        assert frame["observation.nodes.category"][:n] == want["category"]
        assert frame["observation.nodes.filled"][:n] == want["filled"]
        assert frame["observation.nodes.visible"][:n] == want["visible"]
        # As LeRobot hands them to a policy (float32), and as its table holds them (float64).
        assert frame["observation.nodes.position"][:n] == [
            [f32(v) for v in p] for p in want["position"]
        ]
        assert raw["observation.nodes.position"][i][:n] == want["position"]
        assert raw["observation.stamp"][i] == scene.stamp
        assert frame["action"] == [
            want["ids"].index(action.object_id),
            want["ids"].index(action.goal_id),
            -1 if action.orientation_index is None else action.orientation_index,
            codes.FAMILY_ACTIONS.index(action.family_action or "none"),
        ]
        assert frame["observation.scene_sequence"] == scene.sequence
        assert frame["index"] == i
        episode = next(e for e in range(len(episodes)) if episodes[e][0] == action.episode_id)
        assert frame["episode_index"] == episode
        assert frame["task"] == episodes[episode][1]
        positions += n
    assert positions > 20 * 5


@VENV_BUILD_TIMEOUT
def test_camera_frames_come_back_pixel_for_pixel(
    robot_log: Path, lerobot: Path, tmp_path: Path
) -> None:
    summary = export_lerobot(robot_log, tmp_path / "dataset", io.StringIO())
    assert summary["cameras"] == ["table"]
    # The frame a decision was made with: the camera's last image logged before the action.
    expected: list[bytes] = []
    latest: bytes | None = None
    for item in read_log(robot_log):
        message = item.decode()
        if isinstance(message, CompressedImage):
            latest = message.data
        elif isinstance(message, Action) and latest is not None:
            expected.append(latest)
    assert summary["frames"] == len(expected) > 0

    got = load_with_lerobot(lerobot, tmp_path / "dataset", tmp_path)

    assert got["camera_keys"] == ["observation.images.table"]
    frames: list[dict[str, Any]] = got["frames"]  # type: ignore[assignment]
    for frame, data in zip(frames, expected, strict=True):
        image = Image.open(io.BytesIO(data)).convert("RGB")
        width, height = image.size
        chw = frame["observation.images.table"]
        assert (len(chw), len(chw[0]), len(chw[0][0])) == (3, height, width)
        hwc = bytes(chw[c][y][x] for y in range(height) for x in range(width) for c in range(3))
        assert hwc == image.tobytes()


def test_a_truncated_log_exports_what_it_can_and_says_where_it_stopped(
    demo_log: Path, tmp_path: Path
) -> None:
    cut = tmp_path / "cut.mcap"
    data = demo_log.read_bytes()
    cut.write_bytes(data[: len(data) // 2])  # a recorder killed mid-write
    readable = source_episodes(cut)
    steps = [step for _, _, s in readable for step in s]
    assert 0 < len(steps) < sum(len(s) for _, _, s in source_episodes(demo_log))
    progress = io.StringIO()

    summary = export_lerobot(cut, tmp_path / "dataset", progress)

    assert summary["frames"] == len(steps)
    truncated = summary["truncated"]
    assert isinstance(truncated, dict)
    assert truncated["last_exported"]["decision_id"] == steps[-1][1].decision_id
    assert truncated["messages_read"] == len(list(read_log(cut)))
    assert "truncated" in progress.getvalue()
    info = json.loads((tmp_path / "dataset" / "meta" / "info.json").read_text())
    assert info["total_frames"] == len(steps) and info["total_episodes"] == len(readable)


def test_a_log_without_decisions_is_refused(tmp_path: Path) -> None:
    empty = tmp_path / "empty.mcap"
    McapLogWriter(empty).close()
    with pytest.raises(LogError, match="no decision"):
        export_lerobot(empty, tmp_path / "dataset", io.StringIO())
