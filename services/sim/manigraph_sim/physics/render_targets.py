"""What every SAPIEN camera here is made with and read through, whatever the process's global
render settings: the tripod camera (``camera``) and the video camera (``video``) alike."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np
import sapien


@contextlib.contextmanager
def default_shaders() -> Iterator[None]:
    """SAPIEN's lit shaders and float pictures for the cameras made meanwhile, whatever the
    process's global choice: a ManiSkill environment made earlier in the process switches to
    its ``minimal`` pack with 8-bit pictures, in which every lit surface read as white (the
    colours and the markers' quiet zone both lost). ``picture_rgb`` reads either kind."""
    previous = sapien.render.get_camera_shader_dir()
    sapien.render.set_camera_shader_dir("default")
    for name, kind in SAPIEN_DEFAULT_PICTURES.items():
        sapien.render.set_picture_format(name, kind)
    try:
        yield
    finally:
        sapien.render.set_camera_shader_dir(previous)


#: The picture formats of SAPIEN's default shader pack (what ManiSkill restores for it too).
SAPIEN_DEFAULT_PICTURES = {
    "Color": "r32g32b32a32sfloat",
    "ColorRaw": "r32g32b32a32sfloat",
    "PositionSegmentation": "r32g32b32a32sfloat",
}


def picture_rgb(camera: sapien.render.RenderCameraComponent) -> np.ndarray:
    """The camera's colour picture as 8-bit RGB, from float or 8-bit render targets."""
    rgba = camera.get_picture("Color")
    if rgba.dtype == np.uint8:
        return np.ascontiguousarray(rgba[..., :3])
    return (np.clip(rgba[..., :3], 0, 1) * 255).astype(np.uint8)
