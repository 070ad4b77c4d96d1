"""The geometric world as a sim backend: episodes, observations and a magic gripper."""

from __future__ import annotations

from typing import Any

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import (
    EpisodeEvent,
    EpisodeRequest,
    GripperOp,
    RobotCommand,
    RobotFeedback,
    Scene,
)
from manigraph_shared.orientations import nearest_orientation
from manigraph_shared.workspace import Workspace
from manigraph_sim.backend_base import EpisodeBackend
from manigraph_sim.dishwasher.dishwasher_world import DishwasherWorld
from manigraph_sim.dishwasher.model import DishwasherLayout
from manigraph_sim.dishwasher.scene import dishwasher_scene
from manigraph_sim.geometric.geometric_world import GeometricWorld
from manigraph_sim.manifest import GRIPPER
from manigraph_sim.observation import observed_scene
from manigraph_sim.tasks.box_geometry import BoxGeometry
from manigraph_sim.tasks.from_request import episode_layout


class GeometricBackend(EpisodeBackend):
    """Registered as ``geometric`` (options: ``manigraph_sim.backends.GeometricOptions``)."""

    abilities = frozenset({GRIPPER})

    def __init__(
        self,
        goal_tolerance: float = 0.01,
        boxes: BoxGeometry | None = None,
        workspace: Workspace | None = None,
    ) -> None:
        super().__init__()
        self.goal_tolerance = goal_tolerance
        #: Where the gripper may go; a command outside is refused (``outside_workspace``).
        self.workspace = workspace or Workspace()
        #: The box tasks' geometry (None: the default, the demonstrations').
        self.boxes = boxes
        self.world: GeometricWorld | None = None
        #: The dishwasher task's world (then ``world`` is None).
        self.dishwasher: DishwasherWorld | None = None

    @classmethod
    def from_options(cls, options: Any) -> GeometricBackend:
        boxes = None
        if options.box_geometry == "physics":
            from manigraph_sim.physics.box_layout import PHYSICS_BOXES

            boxes = PHYSICS_BOXES
        workspace = Workspace.parse(options.workspace) if options.workspace else None
        return cls(options.goal_tolerance, boxes, workspace)

    def reset(self, request: EpisodeRequest, stamp: float) -> EpisodeEvent:
        episode = episode_layout(request, self.boxes)
        layout = episode.layout
        if isinstance(layout, DishwasherLayout):
            self.world, self.dishwasher = None, DishwasherWorld(layout)
            # Success: every dish loaded as preferred, and both racks pushed in.
            required = {dish.id for dish in layout.dishes} | {rack.id for rack in layout.racks}
            return self.begin(request, required, episode.max_steps, stamp)
        self.dishwasher = None
        self.world = GeometricWorld(
            layout.bodies,
            layout.goals,
            self.goal_tolerance,
            containers=layout.containers,
            hide_inside_closed=layout.partially_observable,
        )
        return self.begin(request, layout.required_goals(), episode.max_steps, stamp)

    def scene(self, stamp: float) -> Scene | None:
        if self.request is None:
            return None
        if self.dishwasher is not None:
            self.sequence += 1
            return dishwasher_scene(
                self.dishwasher, self.request.episode_id, stamp, self.sequence, self.ended
            )
        if self.world is None:
            return None
        self.sequence += 1
        return observed_scene(self.world, self.request.episode_id, stamp, self.sequence, self.ended)

    def execute(self, command: RobotCommand, stamp: float) -> RobotFeedback:
        try:
            if self.halted.is_set():
                raise SkillError("stopped", "emergency stop engaged")
            if not self.workspace.contains(command.position):
                raise SkillError("outside_workspace", f"{command.position.as_tuple()}")
            if self.dishwasher is not None and not self.ended:
                self._execute_dishwasher(self.dishwasher, command)
            elif self.world is None or self.ended:
                raise SkillError("no_episode", "no episode is running")
            elif command.op is GripperOp.TOGGLE_TRAY:
                raise SkillError("unsupported", "this task has no trays")
            elif command.op is GripperOp.PICK:
                # Refused before counting: a pick of nothing is not a step of the episode.
                if command.object_id not in self.world.bodies:
                    raise SkillError("unknown_object", command.object_id)
                self.steps += 1  # every attempted pick counts against the step budget
                self.world.pick(command.object_id)
            else:
                self.world.place(command.object_id, np.array(command.position.as_tuple()))
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

    def _execute_dishwasher(self, world: DishwasherWorld, command: RobotCommand) -> None:
        """Picks and rack toggles count against the step budget."""
        if command.op is GripperOp.PLACE:
            position = np.array(command.position.as_tuple())
            world.place(command.object_id, position, nearest_orientation(command.orientation))
            return
        self.steps += 1
        if command.op is GripperOp.PICK:
            world.pick(command.object_id)
        else:
            world.toggle(command.object_id)

    def _check_end(self) -> None:
        if self.dishwasher is not None:
            if self.ended or self.dishwasher.held is not None:
                return
            if self.dishwasher.done() or self.steps >= self.max_steps:
                self.ended = True
            return
        if self.world is None or self.ended or self.world.held is not None:
            return
        if self.required_filled() == len(self.required) or self.steps >= self.max_steps:
            self.ended = True

    def occupied_goals(self) -> set[str]:
        if self.dishwasher is not None:
            world = self.dishwasher
            loaded = {d.id for d in world.dishes.values() if world.loaded_as_preferred(d)}
            return loaded | {r.id for r in world.racks.values() if not r.open}
        assert self.world is not None
        return set(self.world.occupancy())

    def wrong_object_goals(self) -> set[str]:
        if self.world is None:
            return set()
        return set(self.world.wrong_objects())
