"""The dishwasher in SAPIEN: a cabinet articulation with two prismatic racks, dishes as rigid
bodies, all built from boxes (nothing downloaded).

* **Cabinet**: the articulation's fixed root, two side walls and a back wall around where
  the racks stand pushed in (``dishwasher.task.RACK_CENTRES``, the geometric world's).
* **Racks**: one link each on a prismatic joint along x (0: pushed in, ``-RAIL``:
  pulled out towards the robot, 4 cm short of the geometric world's ``RACK_TRAVEL``, and
  reported so: the rack fixture's ``rail``), with joint damping so a rack stays where it is left. A
  rack is a floor whose top is 5 mm above its centre, a pair of 1.5 cm ribs around every plate
  slot (plates stand between them), and a handle: a tab at one side of its front, sticking
  out towards the robot, grasped where ``manigraph_dishwasher.rack_geometry.RACK_GRIP_OFFSET``
  says (the top rack's beside its right side, the bottom rack's beside its left).
* **Dishes**: a plate is a thin box, 6.4 x 6.4 x 1.5 cm (the geometric world's is 8 cm across,
  as wide as the fingers open: the skills could not tilt it); a bowl is an open box (a base
  and four walls), 5 cm across so neighbouring bowl slots (5.5 cm apart) both take one,
  3.5 cm deep. They start on the geometric world's counter cells,
  its rows moved out of the Panda's blind spot near its base and drawn together
  (``physical_counter_x``), resting at their own height.

The task's state is read back off the simulated poses as a
:class:`~manigraph_dishwasher.sim.dishwasher_world.DishwasherWorld`
(:meth:`PhysicsDishwasher.view`), so the geometric world's rules, success test and Scene are
applied unchanged.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Final

import numpy as np
import sapien
from sapien import physx

from manigraph_dishwasher.rack_geometry import (
    RACK_FLOOR_HALF_Y,
    RACK_FLOOR_THICKNESS,
    RACK_FLOOR_TOP,
    RACK_FLOOR_X,
    rack_handle_boxes,
)
from manigraph_dishwasher.rules import SLOT_FIT
from manigraph_dishwasher.sim.dishwasher_world import DishwasherWorld
from manigraph_dishwasher.sim.model import (
    BOWL,
    PLATE,
    SLOT_PITCH,
    Dish,
    DishwasherLayout,
)
from manigraph_dishwasher.sim.scene import dishwasher_scene
from manigraph_shared.messages import Quaternion, Scene
from manigraph_shared.orientations import ORIENTATIONS, postures_like, up_axis_orientation
from manigraph_shared.rotations import rotation_matrix
from manigraph_sim.family import Evaluation, PhysicsTaskWorld, SimFamily
from manigraph_sim.physics.physics_world import PhysicsWorld

Part = tuple[sapien.Pose, np.ndarray]  # a box: pose relative to its body, half size

#: The physical dishes' extents (x, y, z), metres. A plate is 6.4 cm across (the geometric
#: world's is 8 cm, as wide as the Panda's fingers open): the turn-over manoeuvre takes a
#: plate lying flat across its width.
PHYSICAL_DISH_SIZE: Final = {PLATE: (0.064, 0.064, 0.015), BOWL: (0.05, 0.05, 0.035)}
BOWL_WALL: Final = 0.004
#: The physical counter's rows: the geometric world's cells (x = 0.20, 0.30, 0.40 m, dishes
#: jittered by up to 1 cm) moved to start at 0.30 m, 8 cm apart (0.30, 0.38, 0.46 m), each
#: dish at half its jitter. The Panda has no top-down IK solution within ~0.29 m of its base
#: at counter height, where the geometric near row is; much beyond 0.46 m a dish lies under a
#: pulled-out rack's front (x = 0.52 m).
COUNTER_ROWS: Final = ((0.20, 0.30), (0.30, 0.38), (0.40, 0.46))
COUNTER_JITTER_SCALE: Final = 0.5
#: A rack's floor relative to its centre: x from the front (robot side) to the back, half
#: width along y, top surface height, thickness.
FLOOR_X: Final = RACK_FLOOR_X
FLOOR_HALF_Y: Final = RACK_FLOOR_HALF_Y
FLOOR_TOP: Final = RACK_FLOOR_TOP
FLOOR_THICKNESS: Final = RACK_FLOOR_THICKNESS
#: Ribs around each plate slot: gap between them (a plate is 1.5 cm thick), height,
#: thickness, and their extent along x relative to the rack centre.
RIB_GAP: Final = 0.023
RIB_HEIGHT: Final = 0.015
RIB_THICKNESS: Final = 0.003
RIB_X: Final = (-0.07, 0.0)
#: Joint damping of a rack's rail, N s / m; rack density, kg / m^3.
RAIL_DAMPING: Final = 30.0
RACK_DENSITY: Final = 500.0
DISH_DENSITY: Final = 600.0
#: Friction of a dish (glazed ceramic on the fingers' rubber pads, the rack, the counter).
#: At the blocks' 2.0, a bowl let go of stayed on an open finger and left with the hand.
DISH_FRICTION: Final = 1.0
#: A rack's detent, N / m: a spring holding it at the end of its rail it is nearer (out
#: past half its travel, in otherwise), as a real rack clicks into place. It keeps a dish
#: set down in a slot from shoving the rack part of the way in (without it, one placement
#: moved a rack 6.5 cm, and the next dish went onto a rib); the hand pulling the handle
#: works against at most DETENT * RAIL / 2 (9 N) before the rack clicks the other way.
DETENT: Final = 150.0
#: How far a rack slides out, metres: 11 cm, not the geometric world's 16 (``RACK_TRAVEL``).
#: Pulled out 16 cm, a rack's front (x = 0.52 m) stood 6 cm from the counter's far row
#: (0.46 m), and a hand taking a dish there (20.8 cm long along its closing axis), or the
#: fingers lifting it, met the rack's floor or the dishes in its near slots. 12 cm left
#: 10 cm: still 4 mm short for a plate on its rim with its faces towards the racks (the
#: closing axis along x), refused on every re-plan in three of ten validation episodes.
#: 11 cm leaves 11 cm: such a plate is taken up to x = 0.465 m, the far row's farthest.
#: The policy reads a rack's open flag and its handle where it physically is (5 cm further
#: out than in training when open); with a dish waiting for a rack never placed elsewhere
#: (``gnn_policy._waiting``), it does not depend on how far they slide in the geometric world
#: (top-bottom, 10 dishes, seeds 20000-20099: 1.0 with racks sliding 12, 11, 10, 9 or 2 cm;
#: 0.87 at 10 cm without that rule).
RAIL: Final = 0.11
#: A dish turned about the vertical by less than this (radians) reads as square: one at rest
#: as laid out, whose pose carries only the solver's noise.
YAW_RESOLUTION: Final = 1e-3
#: A rack counts as pulled out once it has travelled more than this fraction of its rail.
OPEN_FRACTION: Final = 0.5
CABINET_COLOUR = [0.8, 0.8, 0.82, 1.0]
RACK_COLOUR = [0.35, 0.4, 0.5, 1.0]
DISH_COLOUR = {PLATE: [0.95, 0.95, 0.92, 1.0], BOWL: [0.55, 0.75, 0.9, 1.0]}


def on_rim_as_asked(index: int, asked: int) -> int:
    """A plate's orientation ``index`` in a slot that asks ``asked``: ``asked`` if both are
    on the rim (``orientations.PLATE_ON_RIM``: one posture of a symmetric plate), else
    ``index``. In a slot that asks one of them, a plate in any of them stands as asked (a
    plate set down upright between the ribs and read as "side-x" did not count as loaded)."""
    return asked if index in postures_like(PLATE, asked) else index


def yaw_from(q: Quaternion, index: int) -> float:
    """How far a dish at pose ``q``, whose up axis is orientation ``index``'s, is turned
    about the vertical from that orientation, radians in [-pi, pi); 0 under
    ``YAW_RESOLUTION`` (a dish at rest as laid out reads exactly square)."""
    turn = rotation_matrix(q) @ rotation_matrix(ORIENTATIONS[index]).T  # about the vertical, nearly
    yaw = float(np.arctan2(turn[1, 0], turn[0, 0]))
    return 0.0 if abs(yaw) < YAW_RESOLUTION else yaw


def physical_counter_x(x: float) -> float:
    """Where a dish the geometric layout puts at ``x`` on the counter lies in physics."""
    geometric, physical = min(COUNTER_ROWS, key=lambda row: abs(row[0] - x))
    return physical + COUNTER_JITTER_SCALE * (x - geometric)


def _box(low: tuple[float, float, float], high: tuple[float, float, float]) -> Part:
    lo, hi = np.array(low), np.array(high)
    return sapien.Pose((lo + hi) / 2), (hi - lo) / 2


def dish_parts(kind: str) -> list[Part]:
    """A plate's box, or a bowl's base and four walls (opening towards its +z)."""
    sx, sy, sz = PHYSICAL_DISH_SIZE[kind]
    if kind == PLATE:
        return [_box((-sx / 2, -sy / 2, -sz / 2), (sx / 2, sy / 2, sz / 2))]
    w = BOWL_WALL
    parts = [_box((-sx / 2, -sy / 2, -sz / 2), (sx / 2, sy / 2, -sz / 2 + w))]
    parts += [
        _box((-sx / 2, -sy / 2, -sz / 2), (-sx / 2 + w, sy / 2, sz / 2)),
        _box((sx / 2 - w, -sy / 2, -sz / 2), (sx / 2, sy / 2, sz / 2)),
        _box((-sx / 2, -sy / 2, -sz / 2), (sx / 2, -sy / 2 + w, sz / 2)),
        _box((-sx / 2, sy / 2 - w, -sz / 2), (sx / 2, sy / 2, sz / 2)),
    ]
    return parts


def rack_parts(rack_id: str, slot_ys: list[float]) -> list[Part]:
    """A rack's floor, the ribs of its plate slots (at ``slot_ys``) and its handle tab,
    relative to the rack's centre."""
    parts = [
        _box(
            (FLOOR_X[0], -FLOOR_HALF_Y, FLOOR_TOP - FLOOR_THICKNESS),
            (FLOOR_X[1], FLOOR_HALF_Y, FLOOR_TOP),
        )
    ]
    for y in slot_ys:
        for side in (-1.0, 1.0):
            centre = y + side * (RIB_GAP + RIB_THICKNESS) / 2
            parts.append(
                _box(
                    (RIB_X[0], centre - RIB_THICKNESS / 2, FLOOR_TOP),
                    (RIB_X[1], centre + RIB_THICKNESS / 2, FLOOR_TOP + RIB_HEIGHT),
                )
            )
    for low, high in rack_handle_boxes(rack_id):
        parts.append(_box(tuple(low), tuple(high)))
    return parts


def cabinet_parts(closed_centres: list[np.ndarray]) -> list[Part]:
    """Two side walls and a back wall around the pushed-in racks (world frame)."""
    x0 = min(c[0] for c in closed_centres) + FLOOR_X[0]
    x1 = max(c[0] for c in closed_centres) + FLOOR_X[1] + 0.02
    top = max(c[2] for c in closed_centres) + 0.12
    wall_y = FLOOR_HALF_Y + 0.02
    return [
        _box((x0, -wall_y - 0.01, 0.0), (x1, -wall_y, top)),
        _box((x0, wall_y, 0.0), (x1, wall_y + 0.01, top)),
        _box((x1, -wall_y - 0.01, 0.0), (x1 + 0.01, wall_y + 0.01, top)),
    ]


def _sapien_quaternion(q: Quaternion) -> list[float]:
    return [q.w, q.x, q.y, q.z]


class PhysicsDishwasher(PhysicsTaskWorld):
    """The dishwasher and the dishes of ``layout`` added to ``world``'s scene (which must
    not have been stepped with them yet: the caller settles the world afterwards); its state
    is judged by ``family``'s rule (:meth:`evaluate`)."""

    def __init__(self, world: PhysicsWorld, layout: DishwasherLayout, family: SimFamily) -> None:
        self.world = self.physics = world
        self.layout = layout
        self.family = family
        self.racks = {rack.id: rack for rack in layout.racks}
        self.slots = {slot.id: slot for slot in layout.slots}
        self.cabinet = self._build_cabinet()
        self.rails = {joint.name: joint for joint in self.cabinet.active_joints}
        self._rail_index = {name: index for index, name in enumerate(self.rails)}
        for joint in self.rails.values():
            joint.set_drive_properties(DETENT, 0.0)  # the rail's own damping stays as it is
        self._held_at: dict[str, float] = {}
        self._hold_racks()
        world.on_step.append(self._hold_racks)
        material = physx.PhysxMaterial(DISH_FRICTION, DISH_FRICTION, 0.0)
        for dish in layout.dishes:
            world.entities[dish.id] = self._add_dish(dish, material)

    def _build_cabinet(self) -> physx.PhysxArticulation:
        world = self.world
        builder = world.scene.create_articulation_builder()
        root = builder.create_link_builder()
        root.set_name("cabinet")
        for pose, half in cabinet_parts([rack.closed_centre for rack in self.racks.values()]):
            root.add_box_collision(pose, half, density=RACK_DENSITY)
            if world.render:
                root.add_box_visual(pose, half, material=CABINET_COLOUR)
        for rack in self.racks.values():
            link = builder.create_link_builder(root)
            link.set_name(rack.id)
            link.set_joint_name(rack.id)
            link.set_joint_properties(
                "prismatic",
                limits=[[-RAIL, 0.0]],
                pose_in_parent=sapien.Pose(rack.closed_centre),
                pose_in_child=sapien.Pose(),
                damping=RAIL_DAMPING,
            )
            slot_ys = [
                float(s.offset[1])
                for s in self.layout.slots
                if s.rack == rack.id and s.kind == PLATE
            ]
            for pose, half in rack_parts(rack.id, slot_ys):
                link.add_box_collision(pose, half, density=RACK_DENSITY)
                if world.render:
                    link.add_box_visual(pose, half, material=RACK_COLOUR)
        cabinet = builder.build(fix_root_link=True)
        cabinet.set_root_pose(sapien.Pose())
        cabinet.set_qpos(np.array([-RAIL if r.open else 0.0 for r in self.racks.values()]))
        return cabinet

    def _add_dish(self, dish: Dish, material: physx.PhysxMaterial) -> sapien.Entity:
        builder = self.world.scene.create_actor_builder()
        for pose, half in dish_parts(dish.kind):
            builder.add_box_collision(pose, half, material=material, density=DISH_DENSITY)
            if self.world.render:
                builder.add_box_visual(pose, half, material=DISH_COLOUR[dish.kind])
        entity = builder.build(name=dish.id)
        q = _sapien_quaternion(ORIENTATIONS[dish.orientation])
        position = dish.position.copy()
        position[0] = physical_counter_x(float(position[0]))
        up_axis = (2, 2, 1, 1, 0, 0)[dish.orientation]
        position[2] = PHYSICAL_DISH_SIZE[dish.kind][up_axis] / 2  # resting on the counter
        entity.set_pose(sapien.Pose(position, q))
        return entity

    # --- state ------------------------------------------------------------------------------
    def rack_travel(self, rack_id: str) -> float:
        """How far rack ``rack_id`` is pulled out, metres (0: pushed in)."""
        return float(-self.cabinet.qpos[self._rail_index[rack_id]])

    def _hold_racks(self) -> None:
        """Each rack's detent at the end of its rail it is nearer."""
        qpos = self.cabinet.qpos  # (after every physics step: read once)
        for rack_id, joint in self.rails.items():
            out = -float(qpos[self._rail_index[rack_id]]) > OPEN_FRACTION * RAIL
            target = -RAIL if out else 0.0
            if self._held_at.get(rack_id) != target:
                joint.set_drive_target(target)
                self._held_at[rack_id] = target

    def is_open(self, rack_id: str) -> bool:
        return self.rack_travel(rack_id) > OPEN_FRACTION * RAIL

    def view(self, held: str | None) -> DishwasherWorld:
        """The simulated state as the geometric dishwasher world: each dish where it is, with
        the orientation index of its up axis, in the slot it stands in (its rack where it
        physically is, the dish not held); each rack open once it is more than half out, and
        where it is (so its slots and handle are reported where they are, as a camera would
        see them)."""
        racks = [
            replace(rack, open=self.is_open(rack.id), travel=self.rack_travel(rack.id), rail=RAIL)
            for rack in self.racks.values()
        ]
        physical = {rack.id: rack.centre for rack in racks}
        dishes = []
        for dish in self.layout.dishes:
            position, (x, y, z, w) = self.world.pose(dish.id)
            index = up_axis_orientation(Quaternion(x=x, y=y, z=z, w=w))
            slot = None
            if dish.id != held:
                slot = self._slot_near(position, physical)
            yaw = yaw_from(Quaternion(x=x, y=y, z=z, w=w), index)
            if slot is not None and dish.kind == PLATE:
                asked = on_rim_as_asked(index, self.slots[slot].orientation)
                index, yaw = asked, (yaw if asked == index else 0.0)
            dishes.append(
                Dish(
                    dish.id,
                    dish.kind,
                    position,
                    index,
                    slot,
                    extents=PHYSICAL_DISH_SIZE[dish.kind],
                    yaw=yaw,
                )
            )
        world = DishwasherWorld(replace(self.layout, dishes=dishes, racks=racks))
        world.held = held
        return world

    def scene(
        self, episode_id: str, stamp: float, sequence: int, ended: bool, held: str | None
    ) -> Scene:
        return dishwasher_scene(self.view(held), episode_id, stamp, sequence, ended)

    def evaluate(self, held: str | None) -> Evaluation:
        return self.family.evaluate(self.layout, self.view(held))

    def slot_offsets(self) -> dict[str, float]:
        """How far each dish in a rack rests from the slot of its kind nearest it, across
        the rack (x and y), millimetres, with the racks where they physically are. A dish in
        no slot, lying between two, shows how far off it came to rest (issue 33: no bowl
        more than 10 mm off). A dish more than a slot pitch from every slot of its kind (on
        the counter) is left out."""
        centres = {
            r.id: r.closed_centre - np.array([self.rack_travel(r.id), 0.0, 0.0])
            for r in self.racks.values()
        }
        offsets = {}
        for dish in self.layout.dishes:
            position = self.world.pose(dish.id)[0]
            gaps = [centres[s.rack] + s.offset - position for s in self.slots.values()]
            kinds = [s.kind for s in self.slots.values()]
            gap = min(
                (g for g, kind in zip(gaps, kinds, strict=True) if kind == dish.kind),
                key=lambda g: float(np.linalg.norm(g)),
            )
            if float(np.linalg.norm(gap)) <= SLOT_PITCH:
                offsets[dish.id] = 1000.0 * float(np.linalg.norm(gap[:2]))
        return offsets

    def _slot_near(self, position: np.ndarray, rack_centres: dict[str, np.ndarray]) -> str | None:
        best, best_distance = None, SLOT_FIT
        for slot in self.layout.slots:
            distance = float(np.linalg.norm(rack_centres[slot.rack] + slot.offset - position))
            if distance <= best_distance:
                best, best_distance = slot.id, distance
        return best
