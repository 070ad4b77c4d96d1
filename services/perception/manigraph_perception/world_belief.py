"""What perception believes about the world: object permanence, goal filling with
hysteresis, and a stale flag.

* An object that is not seen keeps its last pose (a block under the block placed on it, a
  block inside a closed box) until a marker of it is seen again; before it is ever seen it is
  where the layout says it starts.
* ``visible`` follows the sim's meaning: false only for what a closed box hides under
  partial observability (a box seen open once stays revealed, as in the sim), so the planner
  gets the same graph from either source.
* A goal becomes filled when an object of its category that it accepts (``accepts``: colour,
  label, size, id; ``manigraph_shared.acceptance``) rests within ``fill_enter`` of it and
  stays filled until that object is more than ``fill_exit`` away: a pose that jitters around
  the threshold does not flicker the feature the paper found most fragile on hardware.
* The Scene is ``stale`` when no marker of a layout object was seen in the last frame, or
  no frame arrived for ``stale_after`` seconds: the last world is served, flagged.
* A carried object goes where the robot put it: after the planner's action to move it, the
  gripper closing on something (``JointState.gripper_width`` between ``held_width``) and
  opening again (``let_go`` wider than it held, or fully) means it was released at the
  action's goal; it is believed there until a marker of it says otherwise. A block is let go
  of with the fingers only 2 cm wider than it (``grasp_choice.release_opening``: fully open,
  a finger jammed against a bin's wall), a width inside ``held_width``: so the fingers'
  movement says it, not the width alone. Holding starts with the fingers closing (``let_go``
  narrower than the widest since the action) onto something, so fingers left 6 cm open by
  the last release are not taken for a grip. (The camera may not see it land: in a pyramid,
  the stack the blocks come from can hide the goals behind it.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from manigraph_perception.detection import ObjectPose
from manigraph_perception.resting import RestConfig, Support, rest_on_support
from manigraph_shared.acceptance import admits
from manigraph_shared.messages import (
    Quaternion,
    Scene,
    SceneGoal,
    SceneObject,
    TaskLayout,
    Vector3,
)
from manigraph_shared.rotations import rotation_matrix


@dataclass(frozen=True)
class WorldConfig:
    #: Metres. The sim's own rule is 2 cm from the true pose; perception adds its error (up to
    #: ~1 cm along the viewing ray for the farthest blocks), so a goal fills a little wider.
    #: Goals of stacks and pyramids are 4 cm apart, so a neighbour still never fills one.
    fill_enter: float = 0.025
    fill_exit: float = 0.035
    stale_after: float = 2.0  # seconds without a frame
    #: A box is closed when a cover's centre is within this of its centre, above its rim.
    lid_distance: float = 0.03
    #: Gripper openings (metres) that mean "holding something": a block is 4 cm wide, a
    #: cover's handle 3 cm; the open Panda gripper is 8 cm, closed on nothing 0.
    held_width: tuple[float, float] = (0.005, 0.07)
    #: Fingers this much wider than they were while holding have let go, metres (a block is
    #: let go of 2 cm wider than it; a grip squeezes or loosens by a millimetre or two).
    let_go: float = 0.01
    #: A block's depth along the viewing ray from what it rests on (``resting.py``); None:
    #: the marker pose as measured.
    rest: RestConfig | None = field(default_factory=RestConfig)

    def __post_init__(self) -> None:
        if not 0 < self.fill_enter <= self.fill_exit <= 0.1:
            raise ValueError("fill_enter <= fill_exit must be in (0, 0.1] metres")
        if self.stale_after <= 0:
            raise ValueError("stale_after must be > 0 seconds")


@dataclass
class _Belief:
    position: np.ndarray
    orientation: np.ndarray  # x, y, z, w
    seen: bool = False
    last_seen: float = 0.0


class WorldModel:
    """Takes a layout, then one set of object poses per frame; gives the Scene."""

    def __init__(self, config: WorldConfig | None = None, camera: np.ndarray | None = None) -> None:
        self.config = config or WorldConfig()
        #: The camera's centre in the robot base frame (needed to rest blocks on supports).
        self.camera = None if camera is None else np.asarray(camera, dtype=float)
        self.layout: TaskLayout | None = None
        #: Each object's attributes: the layout's, then what its markers say over them.
        self.attributes: dict[str, dict[str, str | float]] = {}
        self.beliefs: dict[str, _Belief] = {}
        self.filled_by: dict[str, str] = {}  # goal id -> object id
        self.revealed: set[str] = set()
        self.sequence = 0
        self.last_frame = 0.0
        self.last_useful = False
        #: (object id, goal id) of the action being carried out, and whether it is held.
        self.carrying: tuple[str, str] | None = None
        self.holding = False
        #: The narrowest opening while holding (what the fingers closed on), the last opening
        #: seen, and the widest since the action (unknown: infinite).
        self.held_at = 0.0
        self.width = math.inf
        self.widest = math.inf

    def set_layout(
        self, layout: TaskLayout, attributes: dict[str, dict[str, str | float]] | None = None
    ) -> bool:
        """Start believing ``layout``'s episode; False if it is the one already held.
        ``attributes`` (by object id: what its markers say) go over the layout's own."""
        if self.layout is not None and layout.episode_id == self.layout.episode_id:
            return False
        self.layout = layout
        given = attributes or {}
        self.attributes = {o.id: {**o.attributes, **given.get(o.id, {})} for o in layout.objects}
        self.beliefs = {
            o.id: _Belief(np.array(o.position.as_tuple()), np.array([0.0, 0.0, 0.0, 1.0]))
            for o in layout.objects
        }
        self.filled_by = {}
        self.revealed = set()
        self.last_useful = False
        self.carrying = None
        self.holding = False
        return True

    def on_action(self, episode_id: str, object_id: str, goal_id: str) -> None:
        """The planner decided to move ``object_id`` to ``goal_id``."""
        if self.layout is None or episode_id != self.layout.episode_id:
            return
        goals = {g.id for g in self.layout.goals}
        if object_id in self.beliefs and goal_id in goals:
            self.carrying = (object_id, goal_id)
            self.holding = False
            self.widest = self.width

    def on_gripper(self, width: float) -> None:
        """The gripper's opening now: closing on the carried object, then letting go of it at
        its goal, moves it there."""
        self.width = width
        if self.carrying is None or self.layout is None:
            return
        self.widest = max(self.widest, width)
        low, high = self.config.held_width
        if not self.holding:
            if low < width < high and width <= self.widest - self.config.let_go:
                self.holding, self.held_at = True, width  # closed on something
            return
        if width <= low:
            self.holding = False  # closed on nothing: it slipped or was dropped
        elif width < high and width < self.held_at + self.config.let_go:
            self.held_at = min(self.held_at, width)  # still holding
        else:
            object_id, goal_id = self.carrying
            goal = next(g for g in self.layout.goals if g.id == goal_id)
            self.beliefs[object_id].position = np.array(goal.position.as_tuple())
            self.carrying = None
            self.holding = False
            self._update_filled()

    def update(self, poses: list[ObjectPose], stamp: float) -> None:
        """One frame's observations (possibly none)."""
        self.last_frame = stamp
        self.last_useful = False
        # Lowest first: a block's support is posed before the block on it.
        for pose in sorted(poses, key=lambda p: p.base_T_object[2, 3]):
            belief = self.beliefs.get(pose.object_id)
            if belief is None:
                continue
            belief.position = self._resting(pose)
            belief.orientation = quaternion_of(pose.base_T_object[:3, :3])
            belief.seen = True
            belief.last_seen = stamp
            self.last_useful = True
        self._update_filled()
        self._observe_boxes()

    def stale(self, now: float) -> bool:
        return not self.last_useful or now - self.last_frame > self.config.stale_after

    def scene(self, stamp: float, now: float) -> Scene | None:
        if self.layout is None:
            return None
        layout = self.layout
        sizes = {o.id: o.size for o in layout.objects}
        categories = {o.id: o.category for o in layout.objects}
        filled_objects = set(self.filled_by.values())
        objects = [
            SceneObject(
                id=object_id,
                category=categories[object_id],
                position=_vector(belief.position),
                orientation=_quaternion(belief.orientation),
                size=sizes[object_id],
                filled=object_id in filled_objects,
                visible=not self._hidden(belief.position),
                attributes=self.attributes.get(object_id, {}),
            )
            for object_id, belief in self.beliefs.items()
        ]
        goals = [
            SceneGoal(
                id=goal.id,
                category=goal.category,
                position=goal.position,
                filled=goal.id in self.filled_by,
                visible=not self._hidden(np.array(goal.position.as_tuple())),
                accepts=goal.accepts,
            )
            for goal in layout.goals
        ]
        self.sequence += 1
        return Scene(
            episode_id=layout.episode_id,
            stamp=stamp,
            sequence=self.sequence,
            objects=objects,
            goals=goals,
            stale=self.stale(now),
        )

    # --- rules ------------------------------------------------------------------------------
    def _resting(self, pose: ObjectPose) -> np.ndarray:
        """A block's centre moved along the viewing ray onto what it rests on (unchanged for
        a cover, without a camera position, or with no support near)."""
        measured = pose.base_T_object[:3, 3].copy()
        assert self.layout is not None
        objects = {o.id: o for o in self.layout.objects}
        if (
            self.config.rest is None
            or self.camera is None
            or objects[pose.object_id].category.value != "block"
        ):
            return measured
        believed = self.beliefs[pose.object_id].position
        if _ray_distance(self.camera, measured, believed) < self.config.rest.same_place:
            # Seen where it was believed (the image says nothing else): it has not moved.
            return believed.copy()
        rotation = pose.base_T_object[:3, :3]
        size = np.array(objects[pose.object_id].size.as_tuple())
        supports = [Support(0.0)]
        boxes = [
            Support(c.centre.z, (c.centre.x, c.centre.y), (c.inner.x / 2, c.inner.y / 2))
            for c in self.layout.containers
        ]
        supports += boxes
        neighbours = []
        for object_id, belief in self.beliefs.items():
            if object_id == pose.object_id:
                continue
            other = np.array(objects[object_id].size.as_tuple()) / 2
            top = belief.position[2] + _half_height(_unit_rotation(belief.orientation), other * 2)
            supports.append(Support(top, (belief.position[0], belief.position[1]), (0.025, 0.025)))
            if objects[object_id].category.value == "block":
                neighbours.append(belief.position)
        rested = rest_on_support(
            measured,
            self.camera,
            _half_height(rotation, size),
            supports,
            neighbours,
            self.config.rest,
            excluded=boxes,
        )
        return measured if rested is None else rested

    def _update_filled(self) -> None:
        assert self.layout is not None
        objects = {o.id: o for o in self.layout.objects}
        kept: dict[str, str] = {}
        for goal in self.layout.goals:
            target = np.array(goal.position.as_tuple())
            holder = self.filled_by.get(goal.id)
            if holder is not None and self._distance(holder, target) <= self.config.fill_exit:
                kept[goal.id] = holder
                continue
            candidates = [
                (self._distance(object_id, target), object_id)
                for object_id in self.beliefs
                if objects[object_id].category.value == goal.category.value
                and admits(
                    goal.accepts,
                    object_id,
                    objects[object_id].size.as_tuple(),
                    self.attributes.get(object_id, {}),
                )
            ]
            if candidates:
                distance, nearest = min(candidates)
                if distance <= self.config.fill_enter:
                    kept[goal.id] = nearest
        self.filled_by = kept

    def _distance(self, object_id: str, target: np.ndarray) -> float:
        return float(np.linalg.norm(self.beliefs[object_id].position - target))

    def _closed(self, box_id: str) -> bool:
        assert self.layout is not None
        box = next(c for c in self.layout.containers if c.id == box_id)
        centre = np.array([box.centre.x, box.centre.y])
        return any(
            o.category.value == "cover"
            and np.linalg.norm(self.beliefs[o.id].position[:2] - centre) < self.config.lid_distance
            and self.beliefs[o.id].position[2] > box.inner.z
            for o in self.layout.objects
        )

    def _observe_boxes(self) -> None:
        assert self.layout is not None
        for box in self.layout.containers:
            if box.id not in self.revealed and not self._closed(box.id):
                self.revealed.add(box.id)

    def _hidden(self, point: np.ndarray) -> bool:
        assert self.layout is not None
        if not self.layout.partially_observable:
            return False
        for box in self.layout.containers:
            inside = (
                abs(point[0] - box.centre.x) <= box.inner.x / 2
                and abs(point[1] - box.centre.y) <= box.inner.y / 2
                and point[2] <= box.inner.z
            )
            if inside and box.id not in self.revealed:
                return True
        return False


def _vector(values: np.ndarray) -> Vector3:
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def _quaternion(xyzw: np.ndarray) -> Quaternion:
    q = np.asarray(xyzw, dtype=float)
    q = q / np.linalg.norm(q)
    if q[3] < 0:
        q = -q
    return Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))


def _ray_distance(camera: np.ndarray, through: np.ndarray, point: np.ndarray) -> float:
    """How far ``point`` is from the ray from ``camera`` through ``through``."""
    ray = (through - camera) / np.linalg.norm(through - camera)
    offset = point - camera
    return float(np.linalg.norm(offset - (offset @ ray) * ray))


def _half_height(rotation: np.ndarray, size: np.ndarray) -> float:
    """Half the height of a box resting on the face nearest to horizontal (its axis nearest
    to vertical: a slightly tilted pose estimate does not make it taller)."""
    return float(size[int(np.argmax(np.abs(rotation[2])))]) / 2


def _unit_rotation(xyzw: np.ndarray) -> np.ndarray:
    """The rotation of an estimated quaternion, normalised first."""
    return rotation_matrix(np.asarray(xyzw, dtype=float) / np.linalg.norm(xyzw))


def quaternion_of(rotation: np.ndarray) -> np.ndarray:
    """(x, y, z, w) of a rotation matrix (of an affine map's nearest rotation)."""
    u, _, vt = np.linalg.svd(rotation)
    r = u @ vt
    if np.linalg.det(r) < 0:
        r = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    w = np.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = np.sqrt(max(0.0, 1.0 + r[0, 0] - r[1, 1] - r[2, 2])) / 2
    y = np.sqrt(max(0.0, 1.0 - r[0, 0] + r[1, 1] - r[2, 2])) / 2
    z = np.sqrt(max(0.0, 1.0 - r[0, 0] - r[1, 1] + r[2, 2])) / 2
    x = np.copysign(x, r[2, 1] - r[1, 2])
    y = np.copysign(y, r[0, 2] - r[2, 0])
    z = np.copysign(z, r[1, 0] - r[0, 1])
    return np.array([x, y, z, w])
