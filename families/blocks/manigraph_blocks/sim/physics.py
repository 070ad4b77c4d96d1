"""The block family in the physics backend: the simulated poses read back as a geometric world.

Whether a goal is filled is decided with the geometric world's rule
(:meth:`GeometricWorld.occupancy`) on the simulated poses: a block fills a goal when its centre
is within the backend's ``goal_tolerance`` of the goal's centre and it is not held. What a
closed box hides is the geometric world's rule too (``GeometricWorld.is_hidden``). Box tasks
are laid out with the physical box geometry (:mod:`.physics_boxes`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from manigraph_blocks.sim.geometric_world import GeometricWorld
from manigraph_blocks.sim.scene import observed_scene
from manigraph_shared.messages import Quaternion, Scene
from manigraph_sim.family import Evaluation, PhysicsTaskWorld, SimFamily
from manigraph_sim.world_model import Body, Layout

if TYPE_CHECKING:
    from manigraph_sim.physics.physics_world import PhysicsWorld


class PhysicsBlocks(PhysicsTaskWorld):
    def __init__(
        self, family: SimFamily, layout: Layout, physics: PhysicsWorld, goal_tolerance: float
    ) -> None:
        self.family = family
        self.layout = layout
        self.physics = physics
        self.goal_tolerance = goal_tolerance
        #: Boxes seen open in this episode: their contents stay observed (partial
        #: observability).
        self.revealed: set[str] = set()

    def view(self, held: str | None) -> GeometricWorld:
        """The simulated poses as a geometric world, to apply its goal and visibility rules."""
        layout = self.layout
        bodies = [
            Body(body.id, body.category, body.size, self.physics.pose(body.id)[0], body.attributes)
            for body in layout.bodies
        ]
        view = GeometricWorld(
            bodies,
            layout.goals,
            self.goal_tolerance,
            containers=layout.containers,
            hide_inside_closed=layout.partially_observable,
        )
        view.revealed = self.revealed  # shared: what observing reveals stays revealed
        view.held = held
        return view

    def scene(
        self, episode_id: str, stamp: float, sequence: int, ended: bool, held: str | None
    ) -> Scene:
        orientations = {}
        for body in self.layout.bodies:
            x, y, z, w = self.physics.pose(body.id)[1]
            orientations[body.id] = Quaternion(x=x, y=y, z=z, w=w)
        return observed_scene(self.view(held), episode_id, stamp, sequence, ended, orientations)

    def evaluate(self, held: str | None) -> Evaluation:
        return self.family.evaluate(self.layout, self.view(held))
