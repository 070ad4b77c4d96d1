"""The Foxglove view's Panda kinematics (tools, no Pinocchio) against the simulated Panda:
every link where SAPIEN puts it, for random arm joints and finger openings."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from manigraph_tools.panda_frames import CHAIN, quat_multiply, world_poses

Loop = Any  # tests/physics/conftest.py: InProcessLoop


def test_every_link_is_where_the_simulated_panda_has_it(loop: Loop) -> None:
    loop.reset()
    world = loop.backend.world
    assert world is not None
    links = {link.name: link for link in world.robot.links}
    rng = np.random.default_rng(0)
    for _ in range(5):
        arm = rng.uniform(-1.5, 1.5, size=7)
        finger = float(rng.uniform(0.0, 0.04))
        world.robot.set_qpos(np.concatenate([arm, [finger, finger]]))
        state = loop.backend.joint_state(time.time())
        assert state is not None
        computed = world_poses(state)
        for name in {link.child for link in CHAIN}:
            pose = links[name].entity_pose
            w, x, y, z = (float(v) for v in pose.q)
            position, rotation = computed[name]
            assert position == pytest.approx(np.asarray(pose.p, dtype=float), abs=1e-4), name
            # q and -q are the same rotation: their product with the inverse is +-identity.
            relative = quat_multiply((-x, -y, -z, w), rotation)
            assert abs(relative[3]) == pytest.approx(1.0, abs=1e-4), name
