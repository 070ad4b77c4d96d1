"""Frames of a physics episode from a fixed camera, written as a GIF or an MP4.

Rendering needs a Vulkan device; on a CPU-only machine that is Mesa's lavapipe (Mesa 25 from
bookworm-backports, see ``scripts/install-vulkan.sh``). The first frame of a process compiles
the shaders (~10 s on 2 cores); later frames take ~30 ms each at 480 x 360.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sapien

from manigraph_shared.errors import ConfigError
from manigraph_sim.physics.render_targets import default_shaders, picture_rgb

#: Where the camera stands and what it looks at (robot base frame, metres): in front of the
#: table, to the robot's left, looking down at the middle of the task workspace.
CAMERA_EYE = np.array([1.05, 0.6, 0.55])
CAMERA_TARGET = np.array([0.42, 0.0, 0.12])


def vulkan_available() -> bool:
    """Whether SAPIEN can open a render system here (a Vulkan device exists)."""
    try:
        sapien.render.RenderSystem()
    except RuntimeError:
        return False
    return True


def look_at(eye: np.ndarray, target: np.ndarray) -> sapien.Pose:
    """A SAPIEN camera pose (x forward, y left, z up) at ``eye`` looking at ``target``."""
    forward = (target - eye) / np.linalg.norm(target - eye)
    left = np.cross([0.0, 0.0, 1.0], forward)
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    matrix = np.eye(4)
    matrix[:3, :3] = np.stack([forward, left, up], axis=1)
    matrix[:3, 3] = eye
    return sapien.Pose(matrix)


@dataclass(frozen=True)
class VideoConfig:
    """``path`` may hold ``{episode}`` and ``{seed}``; without them each episode overwrites
    the file, so the last episode stays. ``.gif`` or ``.mp4`` decides the format."""

    path: str
    fps: float = 15.0
    speed: float = 2.0  # seconds of simulated time per second of video
    width: int = 480
    height: int = 360

    def __post_init__(self) -> None:
        if Path(self.path).suffix.lower() not in (".gif", ".mp4"):
            raise ConfigError("video", f"'{self.path}' must end in .gif or .mp4")
        if not 1 <= self.fps <= 60:
            raise ConfigError("video.fps", "must be in [1, 60]")
        if not 0.1 <= self.speed <= 20:
            raise ConfigError("video.speed", "must be in [0.1, 20]")
        if not (16 <= self.width <= 1920 and 16 <= self.height <= 1080):
            raise ConfigError("video.size", "width in [16, 1920], height in [16, 1080]")


class EpisodeVideo:
    """Attach to a rendering ``PhysicsWorld``; collects a frame every 1/fps of video time."""

    def __init__(self, config: VideoConfig, scene: sapien.Scene, timestep: float) -> None:
        self.config = config
        self.every = max(1, round(config.speed / (config.fps * timestep)))
        self.frames: list[np.ndarray] = []
        self._steps = 0
        scene.set_ambient_light([0.45, 0.45, 0.45])
        scene.add_directional_light([0.3, 0.5, -1.0], [0.8, 0.8, 0.8])
        with default_shaders():
            self.camera = scene.add_camera("video", config.width, config.height, 0.9, 0.01, 10.0)
        self.camera.entity.set_pose(look_at(CAMERA_EYE, CAMERA_TARGET))
        self.scene = scene

    def on_step(self) -> None:
        if self._steps % self.every == 0:
            self.capture()
        self._steps += 1

    def capture(self) -> None:
        self.scene.update_render()
        self.camera.take_picture()
        self.frames.append(picture_rgb(self.camera))

    def write(self, episode: str, seed: int) -> Path:
        """Write the frames so far; returns the file written."""
        import imageio.v2 as imageio

        path = Path(self.config.path.format(episode=episode, seed=seed))
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix.lower() == ".gif":
            imageio.mimsave(path, [*self.frames], duration=1000 / self.config.fps, loop=0)
        else:
            imageio.mimsave(path, [*self.frames], fps=self.config.fps, macro_block_size=8)
        return path
