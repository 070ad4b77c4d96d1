"""The shelf family: blocks from the table into the slots of a shelf's boards, back slots
before the front slots that block them (:mod:`manigraph_shelf.shelf_geometry`).

Its task is ``shelf`` (:mod:`.task`); its world is :mod:`.shelf_world`, observed as a Scene
by :mod:`.scene`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_shared.messages import GripperOp, RobotCommand, Scene
from manigraph_shelf.sim import task as _task  # noqa: F401  (registers it)
from manigraph_shelf.sim.layout import ShelfLayout
from manigraph_shelf.sim.options import ShelfOptions
from manigraph_shelf.sim.scene import shelf_scene
from manigraph_shelf.sim.shelf_world import ShelfWorld
from manigraph_sim.family import (
    Evaluation,
    GeometricTaskWorld,
    MakePhysicsWorld,
    PhysicsTaskWorld,
    SimFamily,
)
from manigraph_sim.tasks.base import Task


class ShelfFamily(SimFamily):
    """Shelf filling (``ShelfLayout``).

    **Success Conditions** (:meth:`evaluate`): every slot holds a block. The goals counted
    are the slots; any block fills any slot, so no goal holds a wrong object.
    """

    name = "shelf"
    help = "shelf filling: blocks into a shelf's slots, from the front, back slots first"
    options_type = ShelfOptions
    layout_type = ShelfLayout
    tasks = ("shelf",)
    request_fields = ("objects",)

    def max_steps(self, task: Task[Any], layout: ShelfLayout) -> int:
        return task.max_steps(len(layout.slots))

    def evaluate(self, layout: ShelfLayout, world: ShelfWorld) -> Evaluation:
        required = frozenset(slot.id for slot in layout.slots)
        filled = required & world.filled()
        return Evaluation(required, filled, success=filled == required)

    def geometric_world(self, layout: ShelfLayout, goal_tolerance: float) -> ShelfTaskWorld:
        return ShelfTaskWorld(self, layout, goal_tolerance)

    def physics_world(
        self, layout: ShelfLayout, make_world: MakePhysicsWorld, goal_tolerance: float
    ) -> PhysicsTaskWorld:
        from manigraph_shelf.sim.physics import physics_shelf

        return physics_shelf(self, layout, make_world, goal_tolerance)


class ShelfTaskWorld(ShelfWorld, GeometricTaskWorld):
    """The shelf world in the geometric backend: every attempted pick counts a step."""

    def __init__(self, family: ShelfFamily, layout: ShelfLayout, goal_tolerance: float) -> None:
        super().__init__(layout, goal_tolerance)
        self.family = family
        self.layout = layout

    def execute(self, command: RobotCommand, count_step: Callable[[], None]) -> None:
        if command.op is GripperOp.PICK:
            # Refused before counting: a pick of nothing is not a step of the episode.
            if command.object_id not in self.positions:
                raise SkillError("unknown_object", command.object_id)
            count_step()
            self.pick(command.object_id)
        elif command.op is GripperOp.PLACE:
            self.place(command.object_id, np.array(command.position.as_tuple()))
        else:
            raise SkillError("unsupported", f"the shelf has no {command.op.value}")

    def scene(self, episode_id: str, stamp: float, sequence: int, ended: bool) -> Scene:
        return shelf_scene(self, self.layout, episode_id, stamp, sequence, ended)

    def evaluate(self) -> Evaluation:
        return self.family.evaluate(self.layout, self)
