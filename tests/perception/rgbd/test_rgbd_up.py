"""``manigraph up --scene-source rgbd`` refuses what it cannot run, before starting anything."""

from __future__ import annotations

import pytest

from manigraph_shared.errors import CONFIG_EXIT_CODE
from manigraph_testkit.testing import run_up

pytestmark = pytest.mark.integration


def test_rgbd_needs_the_physics_sim() -> None:
    result = run_up("--scene-source", "rgbd", "--episodes", "1", check=False)
    assert result.returncode == CONFIG_EXIT_CODE
    assert "scene-source: rgbd needs --sim physics (it renders)" in result.stderr


def test_rgbd_without_a_vulkan_device_is_refused() -> None:
    result = run_up(
        "--sim", "physics", "--scene-source", "rgbd", "--episodes", "1",
        env={"VK_ICD_FILENAMES": "/nonexistent/icd.json"}, check=False,
    )  # fmt: skip
    assert result.returncode == CONFIG_EXIT_CODE
    assert "--scene-source rgbd" in result.stderr and "Vulkan" in result.stderr
