"""The Panda drivers' turn-over manoeuvre: tilt a dish on the counter until its up axis is
the one its placement asks for (``turn_over`` says which tilts;
``motion.tilt`` plans them), Pinocchio-planned and arm-collision-checked like every motion.

Each tilt: the usual top-down pick, with the fingers closing along the axis the dish turns
about; the hand turned sideways and the dish set down on a free counter spot (where it was
first, else a free neighbouring cell of the counter's 10 cm grid); let go and back off. The
skill then takes the dish top-down, which finishes the turn about the vertical. A dish that
cannot be taken or set down turned where it lies (neighbours, a pulled-out rack's floor
over the far row) is first carried top-down to a free neighbouring cell, nearest the robot
first, and turned there (``move_dish``). So is a dish that lies in a rack but in no slot
(a placement that missed): the rack's floor and slots leave no room to turn it there, so it
goes back to a free cell of the counter first.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from manigraph_dishwasher.fixtures import racks
from manigraph_dishwasher.rack_geometry import RACK_GRIP_OFFSET
from manigraph_dishwasher.skills.turn_over import (
    next_tilts,
    quaternion_of,
    set_down_hands,
    top_down_rotation,
    up_index,
)
from manigraph_shared.errors import SkillError
from manigraph_shared.messages import Scene, SceneObject, Vector3
from manigraph_shared.orientations import ORIENTATION_NAMES
from manigraph_shared.panda import FINGER_BELOW_TCP
from manigraph_shared.rotations import rotation_matrix
from manigraph_skills.drivers.base import PLANNING_FAILURES, Grasp, Motion
from manigraph_skills.grasp_choice import dish_grasp_height, dish_opening, room
from manigraph_skills.motion.collision import Contact, refusal
from manigraph_skills.motion.plan import UP, GraspPlanner
from manigraph_skills.motion.tilt import let_go_sideways, set_down_sideways
from manigraph_skills.motion.trajectory import JointTrajectory
from manigraph_skills.obstacles import Obstacle, scene_obstacles

if TYPE_CHECKING:
    from manigraph_skills.drivers.panda_motion import PandaMotionDriver

log = logging.getLogger("manigraph.skills.turn_over")

#: At most this many tilts per placement (two reach any orientation; one spare for a dish
#: that settled otherwise than planned).
MAX_TILTS = 3
#: How far above the counter a turned dish is let go, metres, lowest first: the sideways
#: hand and wrist need room under them.
DROPS = (0.006, 0.02, 0.035)
#: Other set-down spots: the physical counter grid's pitch (x, y), how far from every other
#: dish's centre a spot must be, and how far from the robot's base (radius, metres; nearer,
#: top-down grasps have no IK solution) and along x: the counter's rows, from the near one
#: (nearer the base, a cell beside the counter passed the radius: a bowl moved twice lay at
#: x = 0.05 m, outside the workspace, and nothing could take it again) to the far one
#: (beyond it the racks slide out over the counter).
SPOT_PITCH = np.array([0.08, 0.1])
SPOT_FREE = 0.09
SPOT_RADIUS = (0.29, 0.6)
SPOT_X = (0.29, 0.46)
MAX_SPOTS = 4
SPARE_Y = 0.42
SPARE_X = (0.36, 0.44)
#: The counter's columns (its rows: from ``SPOT_X[0]`` to ``SPOT_X[1]`` by the pitch), and
#: the height below which a dish lies on the counter, not in a rack (the bottom rack's
#: floor is 12 cm above it).
COUNTER_COLUMNS = np.round(np.arange(-0.3, 0.301, 0.1), 3)
COUNTER_Z = 0.1
#: Lowest TCP for a top-down grasp: the fingertips (``FINGER_BELOW_TCP`` under it) stay this
#: far above the counter.
FINGERTIP_CLEARANCE = 0.002


def set_down_spots(scene: Scene, item: SceneObject, here: np.ndarray) -> list[np.ndarray]:
    """Where the dish may be set down turned (x, y): where it is, a free neighbouring cell
    within reach, then spare spots beside the counter."""
    others = _counter_dishes(scene, item)
    # Beyond the counter's side columns (|y| <= 0.31 m) nothing ever lies: the spare spots,
    # on the dish's side first. A side's only while the rack whose handle is on that side
    # (``rack_geometry.RACK_GRIP_OFFSET``: the top rack's right, the bottom rack's left) is
    # pushed in: pulled out, its handle is over them, and a dish turned there could not be
    # taken again. (The racks are never both out: one side is always free.)
    sides = [1.0, -1.0] if here[1] >= 0 else [-1.0, 1.0]
    for rack in racks(scene):
        if rack.open and rack.id in RACK_GRIP_OFFSET:
            side = float(np.sign(RACK_GRIP_OFFSET[rack.id][1]))
            if side in sides:
                sides.remove(side)
    spare = [np.array([x, side * SPARE_Y]) for side in sides for x in SPARE_X]
    free = [s for s in spare if all(np.linalg.norm(s - o) >= SPOT_FREE for o in others)]
    return [here[:2].copy(), *_neighbour_cells(here, others)[: MAX_SPOTS - 2], *free[:2]]


def free_cells(scene: Scene, item: SceneObject, here: np.ndarray) -> list[np.ndarray]:
    """The free neighbouring cells ``set_down_spots`` offers, those on the counter (not out
    by the spare spots), nearest the robot first: farther from a pulled-out rack's front.
    For a dish lying in a rack (not on the counter), the free counter cells nearest the
    robot, then nearest it along y."""
    others = _counter_dishes(scene, item)
    if not on_counter(here):
        cells = [
            cell
            for x in np.arange(SPOT_X[0] + 0.01, SPOT_X[1] + 0.001, SPOT_PITCH[0])
            for y in COUNTER_COLUMNS
            if _free_in_reach(cell := np.array([float(x), float(y)]), others)
        ]
        cells.sort(key=lambda cell: (float(cell[0]), abs(float(cell[1] - here[1]))))
        return cells[: MAX_SPOTS - 2]
    cells = _neighbour_cells(here, others)[: MAX_SPOTS - 2]
    on_rows = [cell for cell in cells if abs(cell[1]) < SPARE_Y - 0.01]
    return sorted(on_rows, key=lambda cell: float(cell[0]))


def on_counter(position: np.ndarray) -> bool:
    """A dish at ``position`` lies on the counter (not in a rack)."""
    return float(position[2]) < COUNTER_Z


def _counter_dishes(scene: Scene, item: SceneObject) -> list[np.ndarray]:
    """Where every other dish on the counter lies (x, y)."""
    return [
        np.array(o.position.as_tuple()[:2])
        for o in scene.objects
        if o.id != item.id and o.visible and on_counter(np.array(o.position.as_tuple()))
    ]


def _neighbour_cells(here: np.ndarray, others: list[np.ndarray]) -> list[np.ndarray]:
    """The counter grid's cells around ``here`` within reach and no dish near, nearest
    first."""
    offsets = [np.array([dx, dy]) * SPOT_PITCH for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
    offsets.sort(key=lambda o: float(np.linalg.norm(o)))
    cells = [here[:2] + offset for offset in offsets[1:]]
    return [cell for cell in cells if _free_in_reach(cell, others)]


def _free_in_reach(cell: np.ndarray, others: list[np.ndarray]) -> bool:
    """No dish near ``cell``, which is on the counter's rows and within reach."""
    radius = float(np.linalg.norm(cell))
    if not SPOT_RADIUS[0] <= radius <= SPOT_RADIUS[1] or not SPOT_X[0] <= cell[0] <= SPOT_X[1]:
        return False
    return all(np.linalg.norm(cell - other) >= SPOT_FREE for other in others)


def grasp_height_for(centre_z: float) -> float:
    """TCP above a dish's centre for a top-down grasp: at the centre unless the fingertips
    would touch the counter (a plate lying flat)."""
    return max(0.0, FINGER_BELOW_TCP + FINGERTIP_CLEARANCE - centre_z)


def turn_dish(
    driver: PandaMotionDriver,
    decision_id: str,
    item: SceneObject,
    targets: tuple[int, ...],
    scene: Scene,
) -> SceneObject:
    """Tilt ``item`` until its up axis is one of ``targets`` (the first is the one asked; a
    plate on its rim may stand on any edge: ``orientations.postures_like``); the dish as it
    then lies (its position observed when the transport can, its orientation as turned)."""
    position = np.array(item.position.as_tuple())
    dish = rotation_matrix(item.orientation)
    moved = False
    if up_index(dish) not in targets and not on_counter(position):
        # In a rack but in no slot: no room to turn it there; to the counter first.
        cells = free_cells(scene, item, position)
        if not cells:
            raise SkillError("collision", f"{item.id} lies in a rack and no counter cell is free")
        log.info("moving %s out of the rack to turn it over on the counter", item.id)
        position, dish = move_dish(driver, decision_id, item, scene, position, dish, cells)
        moved = True
    for _ in range(MAX_TILTS):
        if up_index(dish) in targets:
            break
        try:
            position, dish = _tilt_once(driver, decision_id, item, targets, scene, position, dish)
        except SkillError as exc:
            if exc.reason not in PLANNING_FAILURES or moved:
                raise
            cells = free_cells(scene, item, position)
            if not cells:
                raise
            # No room to take it or set it down turned here: to a free cell, and turn it there.
            log.info("moving %s to turn it over elsewhere: %s", item.id, exc)
            position, dish = move_dish(driver, decision_id, item, scene, position, dish, cells)
            moved = True
            position, dish = _tilt_once(driver, decision_id, item, targets, scene, position, dish)
    if up_index(dish) not in targets:
        raise SkillError(
            "orientation_unreachable", f"{item.id} did not turn {ORIENTATION_NAMES[targets[0]]}"
        )
    return item.replace(position=_vector(position), orientation=quaternion_of(dish))


def _tilt_once(
    driver: PandaMotionDriver,
    decision_id: str,
    item: SceneObject,
    targets: tuple[int, ...],
    scene: Scene,
    position: np.ndarray,
    dish: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """One tilt of ``item`` (centre at ``position``, rotation ``dish``) towards an up axis in
    ``targets``: where it then lies and its rotation."""
    size = np.array(item.size.as_tuple())
    candidates = next_tilts(dish, size, targets)
    if not candidates:
        raise SkillError(
            "orientation_unreachable",
            f"{item.id} lies {ORIENTATION_NAMES[up_index(dish)]}; the fingers span it "
            f"across no axis that turns it {ORIENTATION_NAMES[targets[0]]}",
        )
    # Every up axis asked for first (a plate on any edge: the wrist may clear the counter
    # with the hand rolled one way only), then those a second tilt turns on from.
    wanted = list(dict.fromkeys([*targets, *(t.up_after for t in candidates)]))
    current = item.replace(position=_vector(position))
    lying = current.replace(orientation=quaternion_of(dish))
    height = dish_grasp_height(scene, lying, position, grasp_height_for(float(position[2])))
    grasp = Grasp(height, 0.0, 0.0, scene_obstacles(scene, current, position), np.pi)
    tcp = position + np.array([0.0, 0.0, height])
    # Closing along the axis with more room beside the dish first (``grasp_choice.room``).
    yaws = list(dict.fromkeys(t.pick_yaw for t in candidates))
    yaws.sort(
        key=lambda yaw: -room(scene, tcp, 0 if abs(np.sin(yaw)) > abs(np.cos(yaw)) else 1, item.id)
    )
    grasp = _pick_for_tilt(driver, decision_id, lying, tcp, yaws, grasp)
    hand = driver.model.tcp_pose(driver.transport.joint_positions()).rotation
    held = hand.T @ dish
    # The dish's centre from the TCP, in the hand's frame (the grasp may be above it).
    centre_in_hand = hand.T @ np.array([0.0, 0.0, -height])
    chosen: list[tuple[np.ndarray, np.ndarray, tuple[Obstacle, ...]]] = []

    def plan(q: np.ndarray) -> JointTrajectory:
        failure: SkillError | None = None
        contacts: dict[tuple[str, str], Contact] = {}
        for spot in set_down_spots(scene, current, position):
            obstacles = scene_obstacles(scene, current, np.array([*spot, 0.0]))
            for side in set_down_hands(hand, dish, wanted):
                half = _half_height(item, side @ held)
                for drop in DROPS:
                    driver.raise_if_stopped()
                    centre = np.array([*spot, half + drop])
                    try:
                        trajectory = set_down_sideways(
                            driver.planner, q, side, centre - side @ centre_in_hand
                        )
                    except SkillError as exc:
                        failure = failure or exc
                        continue
                    trajectory.opening = grasp.opening
                    found = driver.plans.contact(trajectory, obstacles)
                    if found is None:
                        log.info(
                            "setting %s down turned at %s, fingers towards %s",
                            item.id,
                            np.round(centre, 3),
                            np.round(side[:, 2], 2),
                        )
                        chosen[:] = [(side, centre, obstacles)]
                        return trajectory
                    contacts.setdefault((found.link, found.obstacle), found)
        if contacts:
            raise SkillError("collision", f"turning {item.id} over: {refusal(contacts)}")
        raise failure or SkillError("no_ik_solution", f"no spot to set {item.id} down")

    try:
        driver.run_plan(decision_id, plan)
    except SkillError as exc:
        if exc.reason in ("collision", "no_ik_solution"):
            driver.put_back(decision_id, item.id)
        raise
    side, centre, obstacles = chosen[0]
    released = driver.run_plan(
        decision_id, lambda q: _clear_let_go(driver, q, obstacles, grasp.opening)
    )
    seen = driver.transport.object_position(item.id, after=released.stamp)
    log.info("turned %s %s", item.id, ORIENTATION_NAMES[up_index(side @ held)])
    return (seen if seen is not None else centre), side @ held


def move_dish(
    driver: PandaMotionDriver,
    decision_id: str,
    item: SceneObject,
    scene: Scene,
    position: np.ndarray,
    dish: np.ndarray,
    cells: list[np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """Carry the dish top-down, lying as it lies, to the first of ``cells`` it can be set down
    on: where it then lies and its rotation (turned about the vertical as the hand turned)."""
    current = item.replace(position=_vector(position), orientation=quaternion_of(dish))
    # Its centre above what it lies on: the counter, or a rack's floor (then it comes to
    # rest on the counter as it lies, this high).
    resting = float(position[2]) if on_counter(position) else _half_height(item, dish)
    height = dish_grasp_height(scene, current, position, grasp_height_for(resting))
    opening = dish_opening(current)
    taking = Grasp(height, 0.0, 0.0, scene_obstacles(scene, current, position), opening=opening)
    driver.pick(Motion(decision_id, item.id, _vector(position), current.orientation, taking))
    taken = driver.planner.yaw_of(driver.transport.joint_positions())
    failure: SkillError | None = None
    for cell in cells:
        there = np.array([*cell, resting])
        obstacles = scene_obstacles(scene, current, there)
        hand = there + height * UP

        def to_cell(
            planner: GraspPlanner, q: np.ndarray, turn: float, carry_z: float, at: np.ndarray = hand
        ) -> JointTrajectory:
            return planner.place(q, at, taken + turn, carry_z)

        setting_down = Grasp(height, 0.0, 0.0, obstacles, np.pi, opening)
        carry = driver.plans.avoiding(to_cell, setting_down, there, f"moving {item.id}")
        try:
            driver.run_plan(decision_id, carry)
        except SkillError as exc:
            if exc.reason not in PLANNING_FAILURES:
                raise
            failure = failure or exc
            continue
        placed = driver.planner.yaw_of(driver.transport.joint_positions())
        released = driver.release(decision_id, setting_down)
        seen = driver.transport.object_position(item.id, after=released.stamp)
        log.info("moved %s to %s", item.id, np.round(there, 3))
        return (seen if seen is not None else there), _about_vertical(placed - taken) @ dish
    driver.put_back(decision_id, item.id)
    assert failure is not None
    raise failure


def _half_height(item: SceneObject, dish: np.ndarray) -> float:
    """Half the height of ``item`` lying with rotation ``dish``: its centre above the
    counter."""
    size = np.array(item.size.as_tuple())
    return float(size[[2, 2, 1, 1, 0, 0][up_index(dish)]]) / 2


def _about_vertical(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _pick_for_tilt(
    driver: PandaMotionDriver,
    decision_id: str,
    item: SceneObject,
    tcp: np.ndarray,
    yaws: list[float],
    grasp: Grasp,
) -> Grasp:
    """Take the dish with the first of ``yaws`` (each closes along an axis some tilt turns
    it about) whose pick can be planned: the axis with more room may pass a rack's floor or
    a neighbour the other clears. The grasp it was taken with (the fingers opened to its
    width across them)."""
    for index, yaw in enumerate(yaws):
        closing = top_down_rotation(yaw)[:, 1]
        taking = replace(grasp, opening=dish_opening(item, closing))
        try:
            driver.pick_at(decision_id, item.id, tcp, yaw, taking)
            return taking
        except SkillError as exc:
            if exc.reason not in PLANNING_FAILURES or index == len(yaws) - 1:
                raise
            log.info("taking %s for a tilt at yaw %.2f: %s", item.id, yaw, exc)
    raise AssertionError("no yaw to take the dish at")


def _clear_let_go(
    driver: PandaMotionDriver,
    q: np.ndarray,
    obstacles: tuple[Obstacle, ...],
    opening: float | None,
) -> JointTrajectory:
    """The first way of letting go (``tilt.let_go_sideways``), the fingers opening
    ``opening`` apart, that touches nothing."""
    contact = None
    for way in let_go_sideways(driver.planner, q):
        way.opening = opening
        found = driver.plans.contact(way, obstacles)
        if found is None:
            return way
        contact = contact or found
    raise SkillError("collision", f"letting go: {contact} (backing off less, or not at all)")


def _vector(point: np.ndarray) -> Vector3:
    return Vector3(x=float(point[0]), y=float(point[1]), z=float(point[2]))
