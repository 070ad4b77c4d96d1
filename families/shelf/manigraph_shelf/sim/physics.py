"""The shelf in SAPIEN: a static cupboard of boxes (:mod:`manigraph_shelf.cupboard`: its
boards, side walls and back wall, the bottom level standing on the table) and the layout's
4 cm blocks as rigid bodies on the table, where the geometric world lays them out.

The task's state is read back off the simulated poses as the geometric
:class:`~manigraph_shelf.sim.shelf_world.ShelfWorld` (:meth:`PhysicsShelf.view`): each block
where it is, standing in the slot whose position its centre is within the goal tolerance of
(not while it is held), so the family's rule, success test and Scene apply unchanged. The
Scene also says how each block is turned (its orientation as simulated): the skills take a
block square to its faces.
"""

from __future__ import annotations

from typing import Final

import numpy as np
import sapien

from manigraph_shared.messages import Quaternion, Scene
from manigraph_shelf.cupboard import cupboard_panels
from manigraph_shelf.sim.layout import ShelfLayout
from manigraph_shelf.sim.scene import shelf_scene
from manigraph_shelf.sim.shelf_world import ShelfWorld
from manigraph_sim.family import Evaluation, MakePhysicsWorld, PhysicsTaskWorld, SimFamily
from manigraph_sim.physics.physics_world import PhysicsWorld

#: The cupboard's colour when rendering (light wood).
CUPBOARD_COLOUR: Final = [0.78, 0.66, 0.5, 1.0]


class PhysicsShelf(PhysicsTaskWorld):
    """The cupboard of ``layout`` added to ``world`` (whose bodies are the layout's blocks);
    its state judged by ``family``'s rule, a block in a slot within ``goal_tolerance``
    metres of it."""

    def __init__(
        self, world: PhysicsWorld, layout: ShelfLayout, family: SimFamily, goal_tolerance: float
    ) -> None:
        self.world = self.physics = world
        self.layout = layout
        self.family = family
        self.goal_tolerance = goal_tolerance
        builder = world.scene.create_actor_builder()
        for panel in cupboard_panels(layout.geometry):
            pose, half = sapien.Pose(panel.centre), np.array(panel.size) / 2
            builder.add_box_collision(pose, half, material=world.material)
            if world.render:
                builder.add_box_visual(pose, half, material=CUPBOARD_COLOUR)
        builder.build_static(name="shelf")

    def view(self, held: str | None) -> ShelfWorld:
        """The simulated state as the geometric shelf world: each block where it is, in the
        slot its centre is within the goal tolerance of, unless it is held."""
        world = ShelfWorld(self.layout, self.goal_tolerance)
        for body in self.layout.bodies:
            world.positions[body.id] = self.world.pose(body.id)[0]
        for slot in self.layout.slots:
            centre = np.array(slot.position)
            for body_id, position in world.positions.items():
                if body_id == held or body_id in world.occupant.values():
                    continue
                if np.linalg.norm(position - centre) <= self.goal_tolerance:
                    world.occupant[slot.id] = body_id
                    break
        world.held = held
        return world

    def scene(
        self, episode_id: str, stamp: float, sequence: int, ended: bool, held: str | None
    ) -> Scene:
        scene = shelf_scene(self.view(held), self.layout, episode_id, stamp, sequence, ended)
        turned = []
        for item in scene.objects:
            x, y, z, w = (float(v) for v in self.world.pose(item.id)[1])
            turned.append(item.replace(orientation=Quaternion(x=x, y=y, z=z, w=w)))
        return scene.replace(objects=turned)

    def evaluate(self, held: str | None) -> Evaluation:
        return self.family.evaluate(self.layout, self.view(held))


def physics_shelf(
    family: SimFamily, layout: ShelfLayout, make_world: MakePhysicsWorld, goal_tolerance: float
) -> PhysicsShelf:
    """The shelf episode of ``layout`` in a new simulator, settled."""
    world = make_world(list(layout.bodies))
    shelf = PhysicsShelf(world, layout, family, goal_tolerance)
    world.step(round(world.config.settle_time / world.config.timestep))
    return shelf
