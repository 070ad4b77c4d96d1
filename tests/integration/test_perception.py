"""The perception service as a process on a real bus: rendered frames in, Scene out; bad
start-up input refused by name."""

from __future__ import annotations

import queue
import time
from pathlib import Path

import pytest

from manigraph_shared.messages import (
    CompressedImage,
    MarkerDetections,
    Scene,
    ServiceStatus,
    TaskLayout,
)
from manigraph_testkit.testing import Stack, free_port, stack

pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[2]
FRAMES = ROOT / "tests" / "perception" / "frames"
MARKERS = str(ROOT / "examples" / "markers" / "sim.toml")
CALIBRATION = str(ROOT / "examples" / "calibration" / "sim-front.yaml")


def _image(name: str, sequence: int) -> CompressedImage:
    data = (FRAMES / f"{name}.png").read_bytes()
    return CompressedImage(
        camera="front", stamp=time.time(), sequence=sequence, format="png", data=data
    )


def test_perception_turns_bus_images_into_scenes(tmp_path: Path) -> None:
    import json

    record = json.loads((FRAMES / "stack4-start.json").read_text())
    with stack(tmp_path) as running:
        running.start("router")
        running.start(
            "perception",
            "perception",
            "--camera",
            "bus",
            "--markers",
            MARKERS,
            "--calibration",
            CALIBRATION,
        )
        with running.client() as bus:
            running.wait_alive(bus, "perception")
            scenes: queue.Queue[Scene] = queue.Queue()
            detections: queue.Queue[MarkerDetections] = queue.Queue()
            statuses: queue.Queue[ServiceStatus] = queue.Queue()
            bus.subscribe(Scene, scenes.put)
            bus.subscribe(MarkerDetections, detections.put)
            bus.subscribe(ServiceStatus, statuses.put, key="manigraph/status/perception")
            layout = TaskLayout.from_builtins({**record["layout"], "stamp": time.time() - 1.0})
            bus.publish(layout)
            time.sleep(0.5)
            bus.publish(_image("stack4-start", 0))
            scene = scenes.get(timeout=10)
            assert scene.episode_id == "stack-0" and not scene.stale
            assert {o.id for o in scene.objects} == {f"block_{i}" for i in range(4)}
            assert len(detections.get(timeout=5).markers) >= 4
            bad = CompressedImage(
                camera="front", stamp=time.time(), sequence=1, format="jpeg", data=b"junk"
            )
            bus.publish(bad)
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                status = statuses.get(timeout=5)
                if "corrupt 1" in status.detail:
                    break
            else:
                raise AssertionError("the corrupt frame never showed in the status")


def _perception(running: Stack, *args: str) -> str:
    result = running.run("perception", *args, timeout=60)
    assert result.returncode != 0
    return result.stderr


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--camera", "/dev/video97"], "/dev/video97"),
        (["--camera", "bus", "--markers", "/nonexistent.toml"], "nonexistent.toml"),
        (["--camera", "bus", "--calibration", "/nonexistent.yaml"], "nonexistent.yaml"),
        (
            ["--camera", "bus", "--layout", str(ROOT / "examples" / "two-towers.toml")],
            "markers.",
        ),
    ],
)
def test_bad_start_up_input_is_refused_by_name(tmp_path: Path, args: list[str], named: str) -> None:
    defaults = {"--markers": MARKERS, "--calibration": CALIBRATION}
    for flag, value in defaults.items():
        if flag not in args:
            args = [*args, flag, value]
    running = Stack(free_port(), tmp_path)
    stderr = _perception(running, *args)
    assert named in stderr, stderr
