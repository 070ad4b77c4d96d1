"""Arm-link collision checking: the Panda's collision meshes (from its URDF) against the table
and the scene's obstacles, with Pinocchio's geometry model and coal.

The arm model is the URDF's collision geometry, reduced like ``PandaModel`` (fingers locked
open, as they are while the arm moves between grasps, as wide as the trajectory opens them:
``JointTrajectory.opening``): links 1-7, the hand and the finger boxes. Obstacles are boxes
(``manigraph_skills.obstacles``) plus the table, a 3 m x 3 m slab below z = 0 around the
base. Pairs checked:

* every link from 1 to the fingers against every obstacle, except the hand and fingers
  against a *support* (what the moved object stands on, or is set down on);
* every link except the base's (links 0 and 1, which stand on it) against the table.

Between two planned points the arm is checked at interpolated configurations, so that no
point of the arm moves more than ``resolution`` between two checks: a point at distance r
from joint j's axis moves at most r |dq_j|, and no point of the Panda is farther than
``REACH`` from any joint axis, so ``ceil(REACH * sum|dq| / resolution)`` steps suffice.
The default 1 cm is under half the smallest obstacle (a 4 cm block) and the ~1.3 cm gaps the
box layout leaves the fingers.

Most pairs are far apart for a whole segment between two planned points: each segment first
bounds every pair's distance from below (the link's bounding sphere against the obstacle's
box, at either end of the segment, less how far the sphere's centre can move over the
segment: ``LinkSpheres``), and checks only the pairs that bound does not clear at its
samples. Those checks, and so every contact found, are the same as checking every pair; a
carry across the counter checks a handful of pairs instead of ~240 per sample.

A pair already touching at the trajectory's first point (the arm is where it is: a dish just
set down settled against the hand, say) is not a contact of the motion: it is ignored until
the two separate, as long as they do within ``ESCAPE_TIME``; past it, or touching again
after separating, it is a contact like any other. Without this, an arm that ends a motion
touching something in the next scene could never plan its way out.
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
#: Seconds from a trajectory's start within which pairs touching at its first point must
#: come apart (``ArmCollisionModel.first_contact``).
ESCAPE_TIME = 1.5
#: A pair whose lower bound on its distance (``LinkSpheres``) is under this many metres is
#: checked (room for rounding).
NEAR_MARGIN = 1e-3


@dataclass(frozen=True)
class Contact:
    link: str
    obstacle: str
    time: float  # seconds from the trajectory's start

    def __str__(self) -> str:
        return f"{self.link} would touch {self.obstacle} at {self.time:.2f} s"


def refusal(contacts: dict[tuple[str, str], Contact]) -> str:
    """The contacts that refused a motion and its re-plans (each link and obstacle once,
    in the order found), as a ``collision`` refusal's detail."""
    first, *others = contacts.values()
    if not others:
        return f"{first} (and on every re-plan)"
    shown = ", ".join(f"{c.link} would touch {c.obstacle}" for c in others[:3])
    more = f" and {len(others) - 3} more" if len(others) > 3 else ""
    return f"{first}; re-plans: {shown}{more}"


class ArmCollisionModel:
    """Checks joint trajectories of the 7-joint arm against box obstacles and the table."""

    def __init__(self, model: PandaModel, resolution: float = 0.01) -> None:
        if resolution <= 0:
            raise ValueError("resolution: must be > 0 metres")
        self.resolution = resolution
        urdf = str(model.urdf)
        self._full = pin.buildModelFromUrdf(urdf)
        meshes = str(model.urdf.parent)  # mesh paths in the URDF are relative to it
        self._geometry = pin.buildGeomFromUrdf(self._full, urdf, pin.COLLISION, package_dirs=meshes)
        self._openings: dict[int, tuple[pin.Model, pin.Data, pin.GeometryModel]] = {}
        reduced, _, arm = self._opened(None)  # every opening has these links, in this order
        self.links = [reduced.frames[g.parentFrame].name for g in arm.geometryObjects]

    def _opened(self, opening: float | None) -> tuple[pin.Model, pin.Data, pin.GeometryModel]:
        """The arm with its fingers locked ``opening`` apart (None: fully open), built once
        per millimetre of opening."""
        finger = FINGER_OPEN if opening is None else min(opening / 2, FINGER_OPEN)
        key = round(finger * 2000)
        if key not in self._openings:
            full = self._full
            q0 = pin.neutral(full)
            for name in FINGER_JOINTS:
                q0[full.joints[full.getJointId(name)].idx_q] = key / 2000
            locked = [full.getJointId(name) for name in FINGER_JOINTS]
            model, (arm,) = pin.buildReducedModel(full, [self._geometry], locked, q0)
            self._openings[key] = (model, model.createData(), arm)
        return self._openings[key]

    def first_contact(
        self, trajectory: JointTrajectory, obstacles: tuple[Obstacle, ...] = ()
    ) -> Contact | None:
        """The first contact along ``trajectory`` (points and the motion between them),
        except of pairs touching at its first point while they move apart (module doc)."""
        model, model_data, arm = self._opened(trajectory.opening)
        geometry = self._with(obstacles, arm)
        data = pin.GeometryData(geometry)
        spheres = LinkSpheres(model, geometry)
        times = trajectory.times
        positions = trajectory.positions
        start = times[0] if times else 0.0
        escaping = (
            self._touching(model, model_data, geometry, data, positions[0]) if positions else []
        )
        for index, q in enumerate(positions):
            if index == 0:
                samples = [(times[0], q)]
                near = spheres.near(model_data, q, q)
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
                near = spheres.near(model_data, previous, q)
            # Only the pairs that may touch over this segment, less those escaping.
            near[escaping] = False
            data.setActiveCollisionPairs(geometry, spheres.collision_map(near))
            for t, sample in samples:
                if pin.computeCollisions(model, model_data, geometry, data, sample, True):
                    return self._contact(geometry, data, t)
                if escaping:
                    still = [p for p in escaping if pin.computeCollision(geometry, data, p)]
                    if still and t - start > ESCAPE_TIME:
                        return self._pair_contact(geometry, still[0], t)
                    for pair in set(escaping) - set(still):
                        data.activateCollisionPair(pair)  # (near or not: it touches no more)
                    escaping = still
        return None

    def touching(
        self, q: np.ndarray, obstacles: tuple[Obstacle, ...] = (), opening: float | None = None
    ) -> list[Contact]:
        """Every contact of the arm standing at ``q`` (time 0), its fingers ``opening``
        apart (None: fully open)."""
        model, model_data, arm = self._opened(opening)
        geometry = self._with(obstacles, arm)
        data = pin.GeometryData(geometry)
        touching = self._touching(model, model_data, geometry, data, q)
        return [self._pair_contact(geometry, p, 0.0) for p in touching]

    @staticmethod
    def _touching(
        model: pin.Model,
        model_data: pin.Data,
        geometry: pin.GeometryModel,
        data: pin.GeometryData,
        q: np.ndarray,
    ) -> list[int]:
        pin.computeCollisions(model, model_data, geometry, data, q, False)
        return [
            index
            for index in range(len(geometry.collisionPairs))
            if data.collisionResults[index].isCollision()
        ]

    # --- pieces -------------------------------------------------------------------------------
    def _with(self, obstacles: tuple[Obstacle, ...], arm: pin.GeometryModel) -> pin.GeometryModel:
        geometry = pin.GeometryModel(arm)
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
        for index in range(len(geometry.collisionPairs)):
            if data.activeCollisionPairs[index] and data.collisionResults[index].isCollision():
                return self._pair_contact(geometry, index, t)
        return Contact("arm", "?", t)

    def _pair_contact(self, geometry: pin.GeometryModel, index: int, t: float) -> Contact:
        pair = geometry.collisionPairs[index]
        return Contact(self.links[pair.first], geometry.geometryObjects[pair.second].name, t)


class LinkSpheres:
    """Which collision pairs of ``geometry`` (an arm link against a static box: an obstacle
    or the table) may touch while the arm moves straight in joint space between two
    configurations.

    Each link's collision shape lies in a sphere (its local bounding box's); a pair's
    distance is at least the sphere's distance to the box. Over a straight joint motion
    ``dq`` the sphere's centre moves at most ``sum_j reach[j] |dq_j|``, ``reach[j]`` bounding
    its distance from joint j's axis in every configuration: its own joint's axis, exactly;
    an earlier joint's, by the lengths of the links between them (triangle inequality). A
    pair clear at either end of the motion by more than that stays clear all along it."""

    def __init__(self, model: pin.Model, geometry: pin.GeometryModel) -> None:
        self.model = model
        pairs = geometry.collisionPairs
        self.ngeoms = len(geometry.geometryObjects)
        self.first = np.array([p.first for p in pairs], dtype=int)
        self.second = np.array([p.second for p in pairs], dtype=int)
        objects = geometry.geometryObjects
        links = sorted(set(self.first.tolist()))
        index = {g: i for i, g in enumerate(links)}
        self.link_of_pair = np.array([index[g] for g in self.first], dtype=int)
        self.joints = [objects[g].parentJoint for g in links]
        self.centres = np.zeros((len(links), 3))  # in the link's joint frame
        self.radii = np.zeros(len(links))
        self.reach = np.zeros((len(links), model.nq))
        for i, g in enumerate(links):
            shape = objects[g].geometry
            shape.computeLocalAABB()
            self.centres[i] = objects[g].placement.act(np.asarray(shape.aabb_center))
            self.radii[i] = shape.aabb_radius
            self.reach[i] = _reach(model, self.joints[i], self.centres[i])
        boxes = sorted(set(self.second.tolist()))
        box_index = {g: i for i, g in enumerate(boxes)}
        self.box_of_pair = np.array([box_index[g] for g in self.second], dtype=int)
        placements = [geometry.geometryObjects[g].placement for g in boxes]
        if any(geometry.geometryObjects[g].parentJoint != 0 for g in boxes):
            raise ValueError("LinkSpheres: every obstacle must be static (joint 0)")
        self.box_centres = np.array([m.translation for m in placements]).reshape(-1, 3)
        self.box_rotations = np.array([m.rotation for m in placements]).reshape(-1, 3, 3)
        self.box_halves = np.array(
            [objects[g].geometry.halfSide for g in boxes], dtype=float
        ).reshape(-1, 3)

    def near(self, data: pin.Data, qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
        """Per pair: whether it may touch anywhere on the straight motion from ``qa`` to
        ``qb`` (the bound above does not clear it)."""
        move = self.reach @ np.abs(np.asarray(qb) - np.asarray(qa))
        clear = np.maximum(self._clearance(data, qa), self._clearance(data, qb))
        return clear - move[self.link_of_pair] <= NEAR_MARGIN

    def collision_map(self, near: np.ndarray) -> np.ndarray:
        """``near`` as the geometry-by-geometry map ``GeometryData.setActiveCollisionPairs``
        takes."""
        active = np.zeros((self.ngeoms, self.ngeoms), dtype=bool)
        active[self.first[near], self.second[near]] = True
        return active

    def _clearance(self, data: pin.Data, q: np.ndarray) -> np.ndarray:
        """Per pair: the link's sphere's distance to the box at ``q`` (negative: overlapping)."""
        pin.forwardKinematics(self.model, data, np.asarray(q, dtype=float))
        frames = [data.oMi[j] for j in self.joints]
        rotations = np.array([m.rotation for m in frames])
        translations = np.array([m.translation for m in frames])
        centres = np.einsum("lij,lj->li", rotations, self.centres) + translations
        points = centres[self.link_of_pair]
        boxes = self.box_of_pair
        local = np.einsum("pji,pj->pi", self.box_rotations[boxes], points - self.box_centres[boxes])
        outside = np.maximum(np.abs(local) - self.box_halves[boxes], 0.0)
        return np.linalg.norm(outside, axis=1) - self.radii[self.link_of_pair]


def _reach(model: pin.Model, joint: int, centre: np.ndarray) -> np.ndarray:
    """Per configuration coordinate: a bound on the distance of ``centre`` (in joint
    ``joint``'s frame) from the axis of that coordinate's joint, in every configuration
    (0 for joints it does not hang from)."""
    reach = np.zeros(model.nq)
    kind = model.joints[joint].shortname() if joint > 0 else ""
    axis = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2}.get(kind)
    distance = float(np.linalg.norm(np.delete(centre, axis) if axis is not None else centre))
    from_origin = float(np.linalg.norm(centre))
    while joint > 0:
        if model.joints[joint].nq != 1:
            raise ValueError("LinkSpheres: one-coordinate joints only")
        reach[model.joints[joint].idx_q] = distance
        from_origin += float(np.linalg.norm(model.jointPlacements[joint].translation))
        joint = model.parents[joint]
        distance = from_origin
    return reach
