"""In-process wiring of the skills' Panda driver to the physics backend (no bus): the same
classes the services run, called directly, so physics behaviour is tested in seconds."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest

from manigraph_lab.in_process import InProcessJointTransport
from manigraph_shared.messages import (
    Action,
    EpisodeRequest,
    Scene,
    SkillStatus,
)
from manigraph_shared.workspace import Workspace
from manigraph_sim.physics.backend import PhysicsBackend
from manigraph_skills.drivers.panda_motion import PandaMotionDriver
from manigraph_skills.pick_and_place import PickAndPlace


class InProcessLoop:
    """Backend + PickAndPlace with the Panda driver; ``move`` runs one decision."""

    def __init__(self, backend: PhysicsBackend, workspace: Workspace | None = None) -> None:
        self.backend = backend
        self.driver = PandaMotionDriver(InProcessJointTransport(backend))
        self.skill = PickAndPlace(self.driver, workspace or Workspace())
        self.decisions = 0

    def reset(
        self, task: str = "stack", blocks: int = 2, seed: int = 0, max_steps: int | None = None
    ) -> Scene:
        request = EpisodeRequest(
            episode_id=f"e{seed}", task=task, blocks=blocks, seed=seed, max_steps=max_steps
        )
        self.backend.reset(request, time.time())
        return self.scene()

    def scene(self) -> Scene:
        scene = self.backend.scene(time.time())
        assert scene is not None
        return scene

    def move(self, object_id: str, goal_id: str) -> SkillStatus:
        scene = self.scene()
        self.decisions += 1
        action = Action(
            decision_id=f"{scene.episode_id}:{self.decisions}",
            episode_id=scene.episode_id,
            scene_sequence=scene.sequence,
            object_id=object_id,
            goal_id=goal_id,
            policy="test",
            stamp=time.time(),
        )
        status = self.skill.execute(action, scene, lambda _status: None)
        self.backend.skill_finished(status)  # as the sim service does with SkillStatus
        return status

    def stack_inverted(self, blocks: int) -> list[SkillStatus]:
        """The expert's answer to ``stack``: top block to the bottom goal, and so on."""
        return [self.move(f"block_{blocks - 1 - i}", f"goal_{i}") for i in range(blocks)]


@pytest.fixture
def make_loop() -> Callable[..., InProcessLoop]:
    """``make_loop(workspace=None, **backend_options)``: a fresh world and driver."""

    def make(workspace: Workspace | None = None, **options: Any) -> InProcessLoop:
        return InProcessLoop(PhysicsBackend(**options), workspace)

    return make


@pytest.fixture
def loop(make_loop: Callable[..., InProcessLoop]) -> InProcessLoop:
    return make_loop()
