"""A block world with honest geometry and no dynamics.

Bodies are axis-aligned boxes. A body rests on the highest body under its footprint, or on the
table; picking a body that has another body on top of it fails; a body released above a goal
falls until it rests on something. A body whose centre is not over what it lands on tips off
over the edge it overhangs and falls again (a block set on a pyramid's top goal with one of
the two blocks under it missing ends beside the other, one level lower), as it would on a
real table. A goal is filled by a body of its category that it accepts (``Goal.accepts``:
attributes, id or size) resting within the tolerance, and only while every goal under it is
filled; a body it does not accept there is a wrong object and leaves it empty. A block that
stands at a pyramid's top goal on a stray block (one that is in no goal) does not fill it,
since the pyramid under it is not there and cannot be finished with the block where it is.
Containers (open-top boxes) are static: a body that fits inside rests on the floor, a wider
one (a cover) rests on the rim and closes the box; what is inside a closed box can be hidden.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from manigraph_shared.errors import SkillError
from manigraph_sim.world_model import CONTACT_MARGIN, Body, Container, Goal


def footprints_overlap(a_pos: np.ndarray, a_size: np.ndarray, b: Body) -> bool:
    gap = np.abs(a_pos[:2] - b.position[:2]) - (a_size[:2] + b.size[:2]) / 2
    return bool(np.all(gap < -CONTACT_MARGIN))


#: Times a released body may tip off an edge before it is left where it lands.
MAX_TIPS = 4


def overlap_extent(
    a_pos: np.ndarray, a_size: np.ndarray, b_pos: np.ndarray, b_size: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The (lo, hi) corners in x, y of where two footprints overlap."""
    lo = np.maximum(a_pos[:2] - a_size[:2] / 2, b_pos[:2] - b_size[:2] / 2)
    hi = np.minimum(a_pos[:2] + a_size[:2] / 2, b_pos[:2] + b_size[:2] / 2)
    return lo, hi


class GeometricWorld:
    def __init__(
        self,
        bodies: list[Body],
        goals: list[Goal],
        goal_tolerance: float = 0.01,
        table_z: float = 0.0,
        containers: list[Container] | None = None,
        hide_inside_closed: bool = False,
    ) -> None:
        self.bodies = {body.id: body for body in bodies}
        self.goals = {goal.id: goal for goal in goals}
        self.goal_tolerance = goal_tolerance
        self.table_z = table_z
        self.containers = containers or []
        #: Partial observability: what is inside a container is not observed until it has
        #: been open once (then it is known, as a robot that looked inside would know it).
        self.hide_inside_closed = hide_inside_closed
        self.revealed: set[str] = set()
        self.held: str | None = None

    # --- queries ----------------------------------------------------------------------------
    def resting(self) -> list[Body]:
        return [b for b in self.bodies.values() if b.id != self.held]

    def covering(self, body: Body) -> list[Body]:
        """Bodies resting on top of ``body``."""
        return [
            other
            for other in self.resting()
            if other is not body
            and other.bottom >= body.top - CONTACT_MARGIN
            and footprints_overlap(other.position, other.size, body)
        ]

    def rest_height(self, position: np.ndarray, size: np.ndarray, ignore: str) -> float:
        """Centre height at which a body of ``size`` released above ``position`` comes to rest."""
        floor = self.table_z
        for box in self.containers:
            if not box.fits_inside(position, size) and box.touches(position, size):
                floor = max(floor, self.table_z + box.height)
        for other in self.resting():
            if other.id != ignore and footprints_overlap(position, size, other):
                floor = max(floor, other.top)
        return floor + float(size[2]) / 2

    def support_extent(
        self, position: np.ndarray, size: np.ndarray, ignore: str
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The x, y bounding box of what holds a body resting at ``position``: the tops and
        container rims its bottom touches. ``None`` on the table (or a container's floor),
        which holds anything."""
        bottom = float(position[2] - size[2] / 2)
        if bottom <= self.table_z + CONTACT_MARGIN:
            return None
        corners: list[tuple[np.ndarray, np.ndarray]] = []
        for box in self.containers:
            rim = self.table_z + box.height
            if abs(rim - bottom) <= CONTACT_MARGIN and box.touches(position, size):
                outer = np.append(box.inner + 2 * box.wall, 0.0)
                corners.append(overlap_extent(position, size, np.append(box.centre, 0.0), outer))
        for other in self.resting():
            if (
                other.id != ignore
                and abs(other.top - bottom) <= CONTACT_MARGIN
                and footprints_overlap(position, size, other)
            ):
                corners.append(overlap_extent(position, size, other.position, other.size))
        if not corners:
            return None
        return np.min([lo for lo, _ in corners], axis=0), np.max([hi for _, hi in corners], axis=0)

    def tip_shift(self, position: np.ndarray, size: np.ndarray, ignore: str) -> np.ndarray | None:
        """How far (x, y) a body resting at ``position`` slides as it tips off the edge its
        centre overhangs, to lie just beyond that edge; ``None`` if its centre is supported."""
        extent = self.support_extent(position, size, ignore)
        if extent is None:
            return None
        lo, hi = extent
        centre = position[:2]
        if np.all(centre >= lo) and np.all(centre <= hi):
            return None
        beyond_hi = hi + size[:2] / 2 + CONTACT_MARGIN - centre
        beyond_lo = lo - size[:2] / 2 - CONTACT_MARGIN - centre
        return np.where(centre > hi, beyond_hi, np.where(centre < lo, beyond_lo, 0.0))

    def settle(self, position: np.ndarray, size: np.ndarray, ignore: str) -> np.ndarray:
        """Where a body of ``size`` released above ``position`` comes to rest, tipping off
        edges it overhangs (at most ``MAX_TIPS`` times)."""
        rest = np.array(position, dtype=float)
        rest[2] = self.rest_height(rest, size, ignore)
        for _ in range(MAX_TIPS):
            shift = self.tip_shift(rest, size, ignore)
            if shift is None:
                break
            rest[:2] += shift
            rest[2] = self.rest_height(rest, size, ignore)
        return rest

    def is_closed(self, box: Container) -> bool:
        """A body rests on the rim over the whole opening."""
        return any(
            body.bottom >= self.table_z + box.height - CONTACT_MARGIN
            and box.touches(body.position, body.size)
            and not box.fits_inside(body.position, body.size)
            and np.all(body.size[:2] >= box.inner)
            for body in self.resting()
        )

    def observe(self) -> None:
        """Note which containers are open now: their contents stay observed from then on."""
        for box in self.containers:
            if box.id not in self.revealed and not self.is_closed(box):
                self.revealed.add(box.id)

    def is_hidden(self, point: np.ndarray) -> bool:
        if not self.hide_inside_closed:
            return False
        return any(
            box.holds_point(point) and box.id not in self.revealed for box in self.containers
        )

    def goal_supports(self) -> dict[str, list[str]]:
        """Goal id -> the goals its object stands on: goals of its category one object
        height lower whose footprints overlap its own (a stack's goal: the one under it; a
        pyramid's: the two under it; a goal on the table or a box floor: none). A goal's
        footprint is that of the category's objects."""
        sizes = {body.category: body.size for body in self.bodies.values()}
        goals = list(self.goals.values())
        supports: dict[str, list[str]] = {goal.id: [] for goal in goals}
        for goal in goals:
            size = sizes.get(goal.category)
            if size is None:
                continue
            for other in goals:
                offset = goal.position - other.position
                if (
                    other.category == goal.category
                    and abs(offset[2] - size[2]) <= CONTACT_MARGIN
                    and bool(np.all(np.abs(offset[:2]) < size[:2] - CONTACT_MARGIN))
                ):
                    supports[goal.id].append(other.id)
        return supports

    def holdings(self) -> dict[str, str]:
        """Goal id -> id of the resting body of its category nearest to it, within
        ``goal_tolerance`` (whether or not the goal accepts it)."""
        bodies = self.resting()
        goals = list(self.goals.values())
        if not bodies or not goals:
            return {}
        body_xyz = np.array([b.position for b in bodies])
        goal_xyz = np.array([g.position for g in goals])
        distance = np.linalg.norm(goal_xyz[:, None, :] - body_xyz[None, :, :], axis=-1)
        same = np.array([[g.category == b.category for b in bodies] for g in goals])
        distance[~same] = np.inf
        held: dict[str, str] = {}
        for row, goal in enumerate(goals):
            column = int(np.argmin(distance[row]))
            if distance[row, column] <= self.goal_tolerance:
                held[goal.id] = bodies[column].id
        return held

    def occupancy(self, judged: Mapping[str, Goal] | None = None) -> dict[str, str]:
        """Goal id -> id of the body it holds (``holdings``), for each goal that accepts that
        body and whose supporting goals (``goal_supports``) are all filled. ``judged``: the
        goals as the judge's rules see them (``world_model.Judge``), else as laid out."""
        rule = judged or self.goals
        held = self.holdings()
        supports = self.goal_supports()
        filled: dict[str, str] = {}
        # Lowest first: a goal's supports come before it.
        for goal in sorted(self.goals.values(), key=lambda goal: float(goal.position[2])):
            body = held.get(goal.id)
            if (
                body is not None
                and rule.get(goal.id, goal).admits(self.bodies[body])
                and all(below in filled for below in supports[goal.id])
            ):
                filled[goal.id] = body
        return {goal_id: filled[goal_id] for goal_id in self.goals if goal_id in filled}

    def wrong_objects(self, judged: Mapping[str, Goal] | None = None) -> dict[str, str]:
        """Goal id -> id of a resting body of its category that stands in it but that it does
        not accept: within ``goal_tolerance`` of it in x and y, the goal's centre inside the
        body's height (so a 7 cm block in a 3 cm block's goal, its centre 2 cm higher, is
        counted), the nearest such body. ``judged``: as :meth:`occupancy`."""
        rule = judged or self.goals
        wrong: dict[str, str] = {}
        for goal in self.goals.values():
            standing = [
                body
                for body in self.resting()
                if body.category == goal.category
                and float(np.linalg.norm(body.position[:2] - goal.position[:2]))
                <= self.goal_tolerance
                and body.bottom - CONTACT_MARGIN <= goal.position[2] <= body.top + CONTACT_MARGIN
            ]
            if not standing:
                continue
            body = min(standing, key=lambda b: float(np.linalg.norm(b.position - goal.position)))
            if not rule.get(goal.id, goal).admits(body):
                wrong[goal.id] = body.id
        return wrong

    def goals_filled(self) -> int:
        return len(self.occupancy())

    # --- actions ----------------------------------------------------------------------------
    def pick(self, body_id: str) -> None:
        if self.held is not None:
            raise SkillError("gripper_full", f"already holding {self.held}")
        body = self.bodies.get(body_id)
        if body is None:
            raise SkillError("unknown_object", body_id)
        on_top = self.covering(body)
        if on_top:
            names = ", ".join(sorted(b.id for b in on_top))
            raise SkillError("object_covered", f"{body_id} is under {names}")
        self.held = body_id

    def place(self, body_id: str, target: np.ndarray) -> np.ndarray:
        """Release the held body above ``target``; it falls to rest. Returns where it rests."""
        if self.held != body_id:
            raise SkillError("not_holding", f"not holding {body_id}")
        body = self.bodies[body_id]
        rest = self.settle(target, body.size, ignore=body_id)
        body.position = rest
        self.held = None
        return rest
