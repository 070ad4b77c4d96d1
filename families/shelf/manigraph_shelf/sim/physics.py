"""The shelf in SAPIEN: a static cupboard of boxes (:mod:`manigraph_shelf.cupboard`: its
boards, side walls and back wall, the bottom level standing on the table) and the layout's
4 cm blocks as rigid bodies on the table, on the geometric world's start cells spread
further apart (:func:`physical_start`).

The task's state is read back off the simulated poses as the geometric
:class:`~manigraph_shelf.sim.shelf_world.ShelfWorld` (:meth:`PhysicsShelf.view`): each block
where it is, standing in the slot whose position its centre is within the goal tolerance of
(not while it is held), so the family's rule, success test and Scene apply unchanged. The
Scene also says how each block is turned (its orientation as simulated): the skills take a
block square to its faces.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Final

import numpy as np
import sapien

from manigraph_shared.messages import Quaternion, Scene
from manigraph_shelf.cupboard import cupboard_panels
from manigraph_shelf.shelf_geometry import start_cells
from manigraph_shelf.sim.layout import ShelfLayout
from manigraph_shelf.sim.scene import shelf_scene
from manigraph_shelf.sim.shelf_world import ShelfWorld
from manigraph_sim.family import Evaluation, MakePhysicsWorld, PhysicsTaskWorld, SimFamily
from manigraph_sim.physics.physics_world import PhysicsWorld

#: The cupboard's colour when rendering (light wood).
CUPBOARD_COLOUR: Final = [0.78, 0.66, 0.5, 1.0]
#: The physical table's start cells: the geometric grid's rows (x = 0.24, 0.32, 0.40 m)
#: moved to these, and its columns (8 cm apart across y) spread to ``START_COLUMN_SPREAD``
#: times as far apart, each block as far off its cell's centre as in the geometric world.
#: The Panda takes a block from its side, its hand pitched down behind the block: the hand
#: is 21 cm wide and reaches 16 cm back along its approach, low over the table, so a block
#: 8 cm beside or behind the one taken was in its way from every side (2 of 10 episodes at
#: 4 blocks succeeded on validation seeds 53200-53209). Columns 12.8 cm apart leave a way in
#: from the robot's side past a block diagonally in front. The near row is moved out of the
#: arm's reach limit by its base (x = 0.24 m: no top-down grasp there).
START_ROWS: Final = {0.24: 0.28, 0.32: 0.35, 0.40: 0.42}
START_COLUMN_SPREAD: Final = 1.6


def physical_start(position: np.ndarray) -> np.ndarray:
    """Where a block the geometric layout starts at ``position`` starts on the physical
    table."""
    cell = min(start_cells(), key=lambda c: float(np.hypot(c[0] - position[0], c[1] - position[1])))
    row = min(START_ROWS, key=lambda x: abs(x - cell[0]))
    moved = position.copy()
    moved[0] = START_ROWS[row] + (position[0] - cell[0])
    moved[1] = START_COLUMN_SPREAD * cell[1] + (position[1] - cell[1])
    return moved


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
    world = make_world([replace(b, position=physical_start(b.position)) for b in layout.bodies])
    shelf = PhysicsShelf(world, layout, family, goal_tolerance)
    world.step(round(world.config.settle_time / world.config.timestep))
    return shelf
