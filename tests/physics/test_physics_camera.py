"""The physics sim's tripod camera (needs a Vulkan device: ``scripts/install-vulkan.sh``;
skipped where there is none): frames, intrinsics, printed markers, ground truth."""

from __future__ import annotations

import time

import cv2
import numpy as np
import pytest

from manigraph_shared.errors import ConfigError
from manigraph_shared.markers import sim_marker_map
from manigraph_shared.messages import CompressedImage, EpisodeRequest
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_sim.physics.camera import CameraConfig, ideal_calibration
from manigraph_sim.physics.video import vulkan_available

pytestmark = pytest.mark.slow


@pytest.mark.skipif(not vulkan_available(), reason="no Vulkan device (scripts/install-vulkan.sh)")
def test_the_camera_sees_every_block_where_it_is() -> None:
    from manigraph_perception.calibration_file import Calibration
    from manigraph_perception.detection import ObjectPoser, detect, detector_for

    backend = PhysicsBackend(camera=CameraConfig(format="png"))
    backend.reset(EpisodeRequest(episode_id="e1", task="stack", blocks=2, seed=3), time.time())
    frame = backend.camera_frame(time.time())
    layout = backend.layout_message(time.time())
    assert frame is not None and layout is not None and backend.world is not None
    image, info = frame
    assert CompressedImage.decode(image.encode()) == image  # fits the contract's limits
    grey = cv2.imdecode(np.frombuffer(image.data, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert grey.shape == (480, 640)
    k, base_T_camera = ideal_calibration(CameraConfig())
    assert np.allclose(np.reshape(info.camera_matrix, (3, 3)), k, atol=1e-3)
    assert np.allclose(backend.camera.base_T_camera(), base_T_camera, atol=1e-5)  # type: ignore[union-attr]
    markers = sim_marker_map()
    sizes = {o.id: np.array(o.size.as_tuple()) for o in layout.objects}
    poser = ObjectPoser(markers, Calibration(k, base_T_camera=base_T_camera), sizes)
    poses = {p.object_id: p for p in poser.poses(detect(detector_for(markers), grey))}
    assert sorted(poses) == ["block_0", "block_1"]
    for object_id, pose in poses.items():
        truth = backend.world.pose(object_id)[0]
        # This stack stands at the far edge (x = 0.33 m, 0.75 m from the camera), where a
        # side marker is 13 px: the p95 bound, not its median (bench_perception).
        assert np.linalg.norm(pose.base_T_object[:3, 3] - truth) < 0.01


def test_camera_settings_are_validated_by_name() -> None:
    with pytest.raises(ConfigError, match="camera-hz"):
        CameraConfig(hz=0)
    with pytest.raises(ConfigError, match=r"camera\.noise"):
        CameraConfig(noise_sigma=-1)


BLUE_AND_RED = """
[[objects]]
id = "block_0"
category = "block"
position = [0.55, -0.08, 0.03]
size = [0.06, 0.06, 0.06]
attributes = { colour = "blue" }

[[objects]]
id = "block_1"
category = "block"
position = [0.55, 0.08, 0.04]
size = [0.08, 0.08, 0.08]
attributes = { colour = "red" }

[[goals]]
id = "goal_0"
category = "block"
position = [0.45, 0.0, 0.02]
"""


@pytest.mark.skipif(not vulkan_available(), reason="no Vulkan device (scripts/install-vulkan.sh)")
def test_the_camera_sees_each_body_in_the_colour_and_size_its_task_gives_it() -> None:
    backend = PhysicsBackend(camera=CameraConfig(format="png"))
    request = EpisodeRequest(
        episode_id="colours", task="file", task_file=BLUE_AND_RED, blocks=2, seed=0
    )
    backend.reset(request, time.time())
    frame = backend.camera_frame(time.time())
    assert frame is not None and backend.world is not None
    image, info = frame
    rgb = cv2.imdecode(np.frombuffer(image.data, np.uint8), cv2.IMREAD_COLOR)[..., ::-1] / 255
    k = np.reshape(info.camera_matrix, (3, 3))
    camera_T_base = np.linalg.inv(backend.camera.base_T_camera())  # type: ignore[union-attr]
    counts = {}
    # The opposite of the colours blocks 0 and 1 get by default (red, then blue).
    for body_id, channel in (("block_0", 2), ("block_1", 0)):  # blue, red
        others = np.delete(rgb, channel, axis=2)
        mask = rgb[..., channel] - others.max(axis=2) > 0.25
        rows, cols = np.nonzero(mask)
        centre = backend.world.pose(body_id)[0]
        u, v, w = k @ (camera_T_base[:3, :3] @ centre + camera_T_base[:3, 3])
        assert len(rows) > 50, body_id
        # Its pixels lie round where the body is (not somewhere else in the picture).
        assert np.hypot(cols.mean() - u / w, rows.mean() - v / w) < 25, body_id
        counts[body_id] = len(rows)
    # Drawn to its size: the 8 cm block shows more of itself round its markers than the 6 cm.
    assert counts["block_1"] > 1.3 * counts["block_0"]
