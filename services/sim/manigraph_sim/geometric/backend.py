"""The geometric world as a sim backend: episodes, observations and a magic gripper.

The world it holds is the episode's task family's (``families``): the backend counts steps and
ends the episode, the family's world carries out commands, draws the Scene and says whether
its goals are filled."""

from __future__ import annotations

from typing import Any

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    EpisodeEvent,
    EpisodeRequest,
    RobotCommand,
    RobotFeedback,
    Scene,
)
from manigraph_shared.workspace import Workspace
from manigraph_sim.backend_base import EpisodeBackend
from manigraph_sim.family import Evaluation, GeometricTaskWorld
from manigraph_sim.manifest import GRIPPER
from manigraph_sim.tasks.from_request import episode_layout


class GeometricBackend(EpisodeBackend):
    """Registered as ``geometric`` (options: ``manigraph_sim.backends.GeometricOptions``)."""

    abilities = frozenset({GRIPPER})

    def __init__(
        self,
        goal_tolerance: float = 0.01,
        box_geometry: str = "geometric",
        workspace: Workspace | None = None,
    ) -> None:
        super().__init__()
        self.goal_tolerance = goal_tolerance
        #: Where the gripper may go; a command outside is refused (``outside_workspace``).
        self.workspace = workspace or Workspace()
        #: The world whose geometry the box tasks are laid out in (``geometric`` or
        #: ``physics``: its roomier boxes, for comparing the two worlds).
        self.box_geometry = box_geometry
        #: The running episode's world: its task family's (None before the first episode).
        self.world: GeometricTaskWorld | None = None

    @classmethod
    def from_options(cls, options: Any) -> GeometricBackend:
        workspace = Workspace.parse(options.workspace) if options.workspace else None
        return cls(options.goal_tolerance, options.box_geometry or "geometric", workspace)

    def reset(self, request: EpisodeRequest, stamp: float) -> EpisodeEvent:
        episode = episode_layout(request, self.box_geometry)
        family, layout = episode.family, episode.layout
        self.world = family.geometric_world(layout, self.goal_tolerance)
        return self.begin(request, family.required_goals(layout), episode.max_steps, stamp)

    def scene(self, stamp: float) -> Scene | None:
        if self.request is None or self.world is None:
            return None
        self.sequence += 1
        return self.world.scene(self.request.episode_id, stamp, self.sequence, self.ended)

    def execute(self, command: RobotCommand, stamp: float) -> RobotFeedback:
        try:
            if self.halted.is_set():
                raise SkillError("stopped", "emergency stop engaged")
            if not self.workspace.contains(command.position):
                raise SkillError("outside_workspace", f"{command.position.as_tuple()}")
            if self.world is None or self.ended:
                raise SkillError("no_episode", "no episode is running")
            self.world.execute(command, self._count_step)
        except SkillError as exc:
            self._check_end()
            return RobotFeedback(
                command_id=command.command_id,
                ok=False,
                reason=exc.reason,
                detail=exc.detail,
                stamp=stamp,
            )
        self._check_end()
        return RobotFeedback(command_id=command.command_id, ok=True, stamp=stamp)

    def _count_step(self) -> None:
        self.steps += 1

    def _check_end(self) -> None:
        if self.world is None or self.ended or self.world.held is not None:
            return
        if self.evaluation().success or self.steps >= self.max_steps:
            self.ended = True

    def evaluation(self) -> Evaluation:
        assert self.world is not None
        return self.world.evaluate()
