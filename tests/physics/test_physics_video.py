"""Rendering a physics episode to a GIF from the fixed camera (needs a Vulkan device:
``scripts/install-vulkan.sh``; skipped where there is none)."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from manigraph_shared.errors import ConfigError
from manigraph_sim.physics.video import VideoConfig, vulkan_available

pytestmark = pytest.mark.slow


@pytest.mark.skipif(not vulkan_available(), reason="no Vulkan device (scripts/install-vulkan.sh)")
def test_an_episode_is_rendered_to_a_gif(make_loop: Callable[..., Any], tmp_path: Path) -> None:
    from PIL import Image

    path = tmp_path / "clip-{seed}.gif"
    loop = make_loop(video=VideoConfig(str(path), fps=10, speed=4, width=160, height=120))
    loop.reset(blocks=1, seed=4)
    assert loop.move("block_0", "goal_0").state.value == "succeeded"
    assert loop.backend.end_event(time.time()) is not None
    (written,) = loop.backend.videos_written
    assert written == tmp_path / "clip-4.gif"
    with Image.open(written) as gif:
        assert gif.size == (160, 120) and gif.n_frames >= 10
        first = np.asarray(gif.convert("RGB"), dtype=float)
        gif.seek(gif.n_frames // 2)
        middle = np.asarray(gif.convert("RGB"), dtype=float)
    assert np.abs(first - middle).mean() > 1.0  # the arm moved in the picture


def test_video_settings_are_validated_by_name() -> None:
    with pytest.raises(ConfigError, match="video"):
        VideoConfig("clip.avi")
    with pytest.raises(ConfigError, match=r"video\.fps"):
        VideoConfig("clip.gif", fps=0)
