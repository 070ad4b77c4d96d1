"""Arm-link collision checking: the Panda's collision meshes (from its URDF) against the table
and the scene's obstacles, with Pinocchio's geometry model and coal.

The arm model is the URDF's collision geometry, reduced like ``PandaModel`` (fingers locked
open, as they are while the arm moves between grasps): links 1-7, the hand and the finger
boxes. Obstacles are boxes (``manigraph_skills.obstacles``) plus the table, a 3 m x 3 m slab
below z = 0 around the base. Pairs checked:

* every link from 1 to the fingers against every obstacle, except the hand and fingers
  against a *support* (what the moved object stands on, or is set down on);
* every link except the base's (links 0 and 1, which stand on it) against the table.

Between two planned points the arm is checked at interpolated configurations, so that no
point of the arm moves more than ``resolution`` between two checks: a point at distance r
from joint j's axis moves at most r |dq_j|, and no point of the Panda is farther than
``REACH`` from any joint axis, so ``ceil(REACH * sum|dq| / resolution)`` steps suffice.
The default 1 cm is under half the smallest obstacle (a 4 cm block) and the ~1.3 cm gaps the
box layout leaves the fingers.
"""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from manigraph_shared.panda import FINGER_JOINTS, FINGER_OPEN
from manigraph_skills.motion.model import PandaModel
from manigraph_skills.motion.trajectory import JointTrajectory
from manigraph_skills.obstacles import Obstacle

#: Farthest any point of the arm is from a joint axis (TCP from the base axis at full
#: reach, plus the fingers), metres.
REACH = 1.2
TABLE_ID = "table"
#: Links that rest on the table (the base, and the shoulder just above it).
ON_TABLE = ("panda_link0", "panda_link1")
#: Links allowed to touch a support.
HAND_LINKS = ("panda_hand", "panda_leftfinger", "panda_rightfinger")


@dataclass(frozen=True)
class Contact:
    link: str
    obstacle: str
    time: float  # seconds from the trajectory's start

    def __str__(self) -> str:
        return f"{self.link} would touch {self.obstacle} at {self.time:.2f} s"


class ArmCollisionModel:
    """Checks joint trajectories of the 7-joint arm against box obstacles and the table."""

    def __init__(self, model: PandaModel, resolution: float = 0.01) -> None:
        if resolution <= 0:
            raise ValueError("resolution: must be > 0 metres")
        self.resolution = resolution
        urdf = str(model.urdf)
        full = pin.buildModelFromUrdf(urdf)
        meshes = str(model.urdf.parent)  # mesh paths in the URDF are relative to it
        geometry = pin.buildGeomFromUrdf(full, urdf, pin.COLLISION, package_dirs=meshes)
        q0 = pin.neutral(full)
        for name in FINGER_JOINTS:
            joint = full.getJointId(name)
            q0[full.joints[joint].idx_q] = FINGER_OPEN
        locked = [full.getJointId(name) for name in FINGER_JOINTS]
        self.model, (self.arm,) = pin.buildReducedModel(full, [geometry], locked, q0)
        self.data = self.model.createData()
        self.links = [self.model.frames[g.parentFrame].name for g in self.arm.geometryObjects]

    def first_contact(
        self, trajectory: JointTrajectory, obstacles: tuple[Obstacle, ...] = ()
    ) -> Contact | None:
        """The first contact along ``trajectory`` (points and the motion between them)."""
        geometry = self._with(obstacles)
        data = pin.GeometryData(geometry)
        times = trajectory.times
        positions = trajectory.positions
        for index, q in enumerate(positions):
            if index == 0:
                samples = [(times[0], q)]
            else:
                previous = positions[index - 1]
                travel = float(np.abs(q - previous).sum())
                steps = max(1, int(np.ceil(REACH * travel / self.resolution)))
                samples = [
                    (
                        times[index - 1] + s * (times[index] - times[index - 1]),
                        previous + s * (q - previous),
                    )
                    for s in np.arange(1, steps + 1) / steps
                ]
            for t, sample in samples:
                if pin.computeCollisions(self.model, self.data, geometry, data, sample, True):
                    return self._contact(geometry, data, t)
        return None

    # --- pieces -------------------------------------------------------------------------------
    def _with(self, obstacles: tuple[Obstacle, ...]) -> pin.GeometryModel:
        geometry = pin.GeometryModel(self.arm)
        table = pin.GeometryObject(
            TABLE_ID, 0, 0, pin.SE3(np.eye(3), np.array([0.5, 0.0, -0.05])), coal.Box(3, 3, 0.1)
        )
        table_id = geometry.addGeometryObject(table)
        for index, link in enumerate(self.links):
            if link not in ON_TABLE:
                geometry.addCollisionPair(pin.CollisionPair(index, table_id))
        for obstacle in obstacles:
            x, y, z, w = obstacle.quaternion
            rotation = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
            placement = pin.SE3(rotation, np.array(obstacle.centre, dtype=float))
            shape = coal.Box(*obstacle.size)
            gid = geometry.addGeometryObject(
                pin.GeometryObject(obstacle.id, 0, 0, placement, shape)
            )
            for index, link in enumerate(self.links):
                if link == "panda_link0" or (obstacle.support and link in HAND_LINKS):
                    continue
                geometry.addCollisionPair(pin.CollisionPair(index, gid))
        return geometry

    def _contact(self, geometry: pin.GeometryModel, data: pin.GeometryData, t: float) -> Contact:
        for index, pair in enumerate(geometry.collisionPairs):
            if data.collisionResults[index].isCollision():
                link = self.links[pair.first]
                return Contact(link, geometry.geometryObjects[pair.second].name, t)
        return Contact("arm", "?", t)
