"""The tasks as ManiSkill environments: ``gym.make``, seeded layouts, the success rule.
ManiSkill needs a Vulkan device even for state observations; skipped where there is none."""

from __future__ import annotations

import numpy as np
import pytest
import sapien

from manigraph_blocks.sim.options import BlockOptions
from manigraph_sim.physics.video import vulkan_available
from manigraph_sim.tasks import get_task

pytestmark = pytest.mark.slow


@pytest.mark.skipif(not vulkan_available(), reason="no Vulkan device (scripts/install-vulkan.sh)")
def test_gym_make_lays_out_the_seeded_task_and_judges_success() -> None:
    import gymnasium as gym

    import manigraph_blocks.sim.maniskill_env  # noqa: F401  (registers the environments)

    env = gym.make("Manigraph-Stack-v0", blocks=2, obs_mode="state")
    try:
        _, info = env.reset(seed=5)
        unwrapped = env.unwrapped
        layout = get_task("stack", BlockOptions(blocks=2)).layout(np.random.default_rng(5))
        for body in layout.bodies:
            placed = unwrapped.blocks[body.id].pose.p[0].numpy()
            assert np.allclose(placed, body.position, atol=1e-5)
        assert not bool(info["success"][0]) and int(info["goals_filled"][0]) == 0
        # Blocks put straight onto their goals fill them: success by the geometric rule.
        for body, goal in zip(layout.bodies, layout.goals, strict=True):
            unwrapped.blocks[body.id].set_pose(sapien.Pose(goal.position + np.array([0.005, 0, 0])))
        info = unwrapped.evaluate()
        assert bool(info["success"][0]) and int(info["goals_filled"][0]) == 2
    finally:
        env.close()


def test_box_packing_as_a_maniskill_env_without_a_render_device() -> None:
    import gymnasium as gym

    import manigraph_blocks.sim.maniskill_env  # noqa: F401  (registers the environments)
    from manigraph_blocks.sim.physics_boxes import PHYSICS_BOXES

    env = gym.make("Manigraph-BoxPack-v0", blocks=2, obs_mode="state", render_backend="none")
    try:
        _, info = env.reset(seed=3)
        unwrapped = env.unwrapped
        params = BlockOptions(blocks=2, boxes=PHYSICS_BOXES)
        layout = get_task("box-pack", params).layout(np.random.default_rng(3))
        (box,) = layout.containers
        assert np.allclose(unwrapped.boxes["box_0"].pose.p[0].numpy()[:2], box.centre, atol=1e-5)
        for body in layout.bodies:
            placed = unwrapped.blocks[body.id].pose.p[0].numpy()
            assert np.allclose(placed, body.position, atol=1e-5)
        # Only the cover is in a goal (its lid goal): not done until the blocks are in.
        assert not bool(info["success"][0]) and int(info["goals_filled"][0]) == 1
        for block, goal in zip(layout.bodies[:2], layout.goals[:2], strict=True):
            unwrapped.blocks[block.id].set_pose(sapien.Pose(goal.position))
        info = unwrapped.evaluate()
        assert bool(info["success"][0]) and int(info["goals_filled"][0]) == 3
    finally:
        env.close()
