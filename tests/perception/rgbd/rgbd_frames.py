"""RGB-D frames rendered by the physics sim, with the truth (for the tests and the bench)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from manigraph_perception.pipelines.rgbd.frames import decode_depth
from manigraph_shared.messages import EpisodeRequest, TaskLayout

ROOT = Path(__file__).resolve().parents[3]
COLOUR_SORT = (ROOT / "examples" / "tasks" / "colour-sort.toml").read_text()


@dataclass
class RenderedFrame:
    name: str
    bgr: np.ndarray
    depth: np.ndarray  # metres, 0: none
    layout: TaskLayout
    #: object id -> (centre, quaternion x y z w) in the robot base frame
    truth: dict[str, tuple[np.ndarray, np.ndarray]]
    attributes: dict[str, dict[str, str | float]]


#: The D400 noise model as is; doubled, with the camera 1 cm and 1 degree off its calibration.
NOMINAL = (1.0, (0.0, 0.0))
DEGRADED = (2.0, (0.01, 1.0))
#: (name, request, (depth noise scale, camera pose error (m, deg)))
EPISODES = [
    ("stack", EpisodeRequest(episode_id="stack", task="stack", blocks=4, seed=3), NOMINAL),
    ("pyramid", EpisodeRequest(episode_id="pyramid", task="pyramid", blocks=6, seed=5), NOMINAL),
    (
        "colour-sort",
        EpisodeRequest(
            episode_id="colour-sort", task="file", task_file=COLOUR_SORT, blocks=4, seed=7
        ),
        NOMINAL,
    ),
    ("stack-degraded", EpisodeRequest(episode_id="sd", task="stack", blocks=4, seed=4), DEGRADED),
]


def render_frames() -> list[RenderedFrame]:
    from manigraph_sim.physics.backend import PhysicsBackend
    from manigraph_sim.physics.camera import CameraConfig
    from manigraph_sim.physics.depth_noise import DepthNoise

    frames = []
    backends: dict[tuple[float, tuple[float, float]], PhysicsBackend] = {}
    for name, request, sensor in EPISODES:
        if sensor not in backends:
            noise, off = sensor
            config = CameraConfig(
                format="png", depth=DepthNoise(scale=noise), markers=False, pose_error=off
            )
            backends[sensor] = PhysicsBackend(camera=config)
        backend = backends[sensor]
        backend.reset(request, time.time())
        frame = backend.camera_frame(time.time())
        depth_message = backend.camera_depth()
        layout = backend.layout_message(time.time())
        assert frame is not None and depth_message is not None and layout is not None
        assert backend.world is not None
        bgr = cv2.imdecode(np.frombuffer(frame[0].data, np.uint8), cv2.IMREAD_COLOR)
        depth = decode_depth(depth_message.data)
        assert depth is not None
        truth = {}
        for o in layout.objects:
            centre, quaternion = backend.world.pose(o.id)
            truth[o.id] = (np.asarray(centre, float), np.asarray(quaternion, float))
        attributes = {o.id: dict(o.attributes) for o in layout.objects}
        frames.append(RenderedFrame(name, bgr, depth, layout, truth, attributes))
    return frames
