"""One short physics episode through the full stack: router, physics sim, planner and skills
(Panda driver) as separate processes over real Zenoh on loopback."""

from __future__ import annotations

import json
from collections import Counter

import pytest

from manigraph_sim.physics.video import vulkan_available
from manigraph_testkit.testing import run_up

#: Frames of the recorded camera the blur is measured on.
MEASURED_FRAMES = 12

pytestmark = pytest.mark.integration


def test_a_physics_stacking_episode_through_every_service() -> None:
    result = run_up(
        "--sim",
        "physics",
        "--task",
        "stack",
        "--blocks",
        "2",
        "--episodes",
        "1",
        "--seed",
        "3",
        timeout=120.0,
    )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate"] == 1.0
    (episode,) = summary["results"]
    assert episode["goals_filled"] == episode["goals_total"] == 2
    assert episode["steps"] == 2
    assert "driver 'panda-sim'" in result.stderr  # up chose the Panda driver for physics


@pytest.mark.slow
@pytest.mark.skipif(not vulkan_available(), reason="no Vulkan device (scripts/install-vulkan.sh)")
def test_a_physics_episode_with_perception_as_the_only_scene_source(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from manigraph_shared.mcap_log import read_log
    from manigraph_shared.messages import CompressedImage, Scene

    log = tmp_path / "camera.mcap"
    result = run_up(
        "--sim",
        "physics",
        "--scene-source",
        "camera",
        "--task",
        "stack",
        "--blocks",
        "1",
        "--episodes",
        "1",
        "--record",
        str(log),
        timeout=300.0,
    )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate"] == 1.0
    images = list(read_log(log, ["manigraph/camera/front/image"]))
    assert images and isinstance(images[0].decode(), CompressedImage)
    scenes = list(read_log(log, [Scene.key]))
    # Perception makes at most one Scene per frame; the sim (10 Hz) would have made many more
    # (tens over the episode). The log may miss a frame or two that perception saw: once, in a
    # fresh-clone run at load ~1.5, it held 5 scenes and 4 images.
    assert 0 < len(scenes) <= len(images) + 2


@pytest.mark.slow
@pytest.mark.skipif(not vulkan_available(), reason="no Vulkan device (scripts/install-vulkan.sh)")
def test_up_degrades_the_camera_it_renders_and_perception_still_sees(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import cv2
    import numpy as np

    from manigraph_perception.deblur import Blur, BlurGauge
    from manigraph_perception.detection import detect, detector_for
    from manigraph_shared.markers import sim_marker_map
    from manigraph_shared.mcap_log import read_log

    log = tmp_path / "blurred.mcap"
    result = run_up(
        *("--sim", "physics", "--scene-source", "camera", "--task", "stack", "--blocks", "2"),
        *("--camera-noise", "5", "--camera-blur", "5", "--episodes", "1", "--seed", "1"),
        *("--record", str(log)),
        timeout=400.0,
    )
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["success_rate"] == 1.0
    images = [message.decode() for message in read_log(log, ["manigraph/camera/front/image"])]
    detector = detector_for(sim_marker_map())._replace(gauge=None)
    gauge = BlurGauge(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_250))
    # The smear is the camera's, on every frame; one noisy frame's gauge may be a pixel off
    # (once 4 for 5), so the camera's smear is the one most of a dozen frames measure.
    measured = []
    for image in images[:: max(1, len(images) // MEASURED_FRAMES)][:MEASURED_FRAMES]:
        grey = cv2.imdecode(np.frombuffer(image.data, np.uint8), cv2.IMREAD_GRAYSCALE)
        found = detect(detector, grey)
        measured.append(gauge.measure(grey, [(m.id, m.corners) for m in found]))
    assert len(measured) >= 3, len(images)
    most, count = Counter(measured).most_common(1)[0]
    assert most == Blur(1, 5) and count > len(measured) // 2, measured
