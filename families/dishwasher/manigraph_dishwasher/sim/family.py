"""The dishwasher family: dishes on a counter, two sliding racks, the paper's loading rules
(docs/dishwasher.md).

Its task is ``dishwasher`` (:mod:`.task`); its world is :mod:`.dishwasher_world`, observed as
a Scene by :mod:`.scene`, and in the physics backend a SAPIEN cabinet and dishes read back as
that world (:mod:`.physics`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from manigraph_dishwasher.sim import task as _task  # noqa: F401  (registers it)
from manigraph_dishwasher.sim.dishwasher_world import DishwasherWorld
from manigraph_dishwasher.sim.model import DishwasherLayout
from manigraph_dishwasher.sim.options import DishwasherOptions
from manigraph_dishwasher.sim.scene import dishwasher_scene
from manigraph_shared.messages import GripperOp, RobotCommand, Scene
from manigraph_shared.orientations import nearest_orientation
from manigraph_sim.family import (
    Evaluation,
    GeometricTaskWorld,
    MakePhysicsWorld,
    PhysicsTaskWorld,
    SimFamily,
)
from manigraph_sim.tasks.base import Task


class DishwasherFamily(SimFamily):
    """Dishwasher loading (``DishwasherLayout``).

    **Success Conditions** (:meth:`evaluate`): every dish stands in a slot its preference
    allows, in that slot's orientation, and both racks are pushed in. The goals counted are
    the dishes and the racks; no goal holds a wrong object (a slot refuses a dish of the
    other kind).
    """

    name = "dishwasher"
    help = "dishwasher loading: dishes into two sliding racks, as preferred"
    options_type = DishwasherOptions
    layout_type = DishwasherLayout
    tasks = ("dishwasher",)
    request_fields = ("objects",)

    def max_steps(self, task: Task[Any], layout: DishwasherLayout) -> int:
        return task.max_steps(len(layout.dishes))

    def required_goals(self, layout: DishwasherLayout) -> set[str]:
        """Every dish (loaded as preferred) and both racks (pushed in)."""
        return {dish.id for dish in layout.dishes} | {rack.id for rack in layout.racks}

    def evaluate(self, layout: DishwasherLayout, world: DishwasherWorld) -> Evaluation:
        required = frozenset(self.required_goals(layout))
        loaded = {d.id for d in world.dishes.values() if world.loaded_as_preferred(d)}
        filled = required & (loaded | {r.id for r in world.racks.values() if not r.open})
        return Evaluation(required, filled, success=filled == required)

    def geometric_world(self, layout: DishwasherLayout, goal_tolerance: float) -> DishesWorld:
        return DishesWorld(self, layout)

    def physics_world(
        self, layout: DishwasherLayout, make_world: MakePhysicsWorld, goal_tolerance: float
    ) -> PhysicsTaskWorld:
        from manigraph_dishwasher.sim.physics import PhysicsDishwasher

        world = make_world([])  # the dishes are the cabinet's to add
        dishwasher = PhysicsDishwasher(world, layout, self)
        world.step(round(world.config.settle_time / world.config.timestep))
        return dishwasher


class DishesWorld(DishwasherWorld, GeometricTaskWorld):
    """The dishwasher world in the geometric backend: picks and rack toggles count steps."""

    def __init__(self, family: DishwasherFamily, layout: DishwasherLayout) -> None:
        super().__init__(layout)
        self.family = family
        self.layout = layout

    def execute(self, command: RobotCommand, count_step: Callable[[], None]) -> None:
        if command.op is GripperOp.PLACE:
            position = np.array(command.position.as_tuple())
            self.place(command.object_id, position, nearest_orientation(command.orientation))
            return
        count_step()
        if command.op is GripperOp.PICK:
            self.pick(command.object_id)
        else:
            self.toggle(command.object_id)

    def scene(self, episode_id: str, stamp: float, sequence: int, ended: bool) -> Scene:
        return dishwasher_scene(self, episode_id, stamp, sequence, ended)

    def evaluate(self) -> Evaluation:
        return self.family.evaluate(self.layout, self)
