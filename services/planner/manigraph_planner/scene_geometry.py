"""Geometric relations read off a Scene: what rests on what, what is under a cover.

:class:`SceneGeometry` computes every relation of one scene at once with numpy (K objects,
L goals: one K x K and one L x K comparison), so the expert's decision at K = 40 costs tens
of microseconds instead of the milliseconds of pairwise Python loops. The comparisons are the
same floating-point expressions, in the same order, as the per-pair definitions they replaced,
which tests/planner/test_scene_geometry.py keeps as the reference they must agree with.
"""

from __future__ import annotations

import numpy as np

from manigraph_shared.messages import Scene, SceneGoal, SceneObject

MARGIN = 0.002


class SceneGeometry:
    """Which objects rest over which objects and which goals, for one scene."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        objects = scene.objects
        self._index = {o.id: i for i, o in enumerate(objects)}
        boxes = np.array(
            [
                (o.position.x, o.position.y, o.position.z, o.size.x, o.size.y, o.size.z)
                for o in objects
            ],
            dtype=np.float64,
        ).reshape(len(objects), 6)
        columns = np.ascontiguousarray(boxes.T)  # (6, K): x, y, z, size x, y, z
        footprint, z, size_z = columns[0:2], columns[2], columns[5]
        reach = columns[3:5] / 2  # half of each footprint, (2, K)
        self._visible = np.array([o.visible for o in objects], dtype=bool)
        self._bottom = z - size_z / 2
        top = z + size_z / 2
        # resting[i, j]: object j rests over object i (overlapping footprint, above i's top).
        rests = (self._bottom[None, :] >= (top - MARGIN)[:, None]) & _overlap(
            footprint, reach, footprint, reach
        )
        np.fill_diagonal(rests, False)
        self._rests = rests
        goals = scene.goals
        self._goal_index = {g.id: i for i, g in enumerate(goals)}
        spots = np.ascontiguousarray(
            np.array([(g.position.x, g.position.y, g.position.z) for g in goals], dtype=np.float64)
            .reshape(len(goals), 3)
            .T
        )
        # above[l, j]: visible object j is higher than goal l, over its position.
        self._above = (
            self._visible[None, :]
            & (self._bottom[None, :] > spots[2][:, None])
            & _overlap(spots[0:2], 0.0, footprint, reach)
        )
        # Per-entity answers as Python lists: a policy asks once per object and goal.
        self._covered: list[bool] = rests.any(axis=1).tolist()
        self._blocked: list[bool] = self._above.any(axis=1).tolist()

    def is_covered(self, item: SceneObject) -> bool:
        """Another object rests on top of ``item`` (overlapping footprint, above its top)."""
        return self._covered[self._index[item.id]]

    def is_blocked(self, goal: SceneGoal) -> bool:
        """A visible object lies over ``goal`` (it cannot be filled before that is moved)."""
        return self._blocked[self._goal_index[goal.id]]

    def objects_over(self, item: SceneObject) -> list[SceneObject]:
        """Visible objects resting over ``item`` (what must be lifted before it is picked)."""
        row = self._rests[self._index[item.id]] & self._visible
        return [self.scene.objects[j] for j in np.flatnonzero(row)]

    def objects_above_goal(self, goal: SceneGoal) -> list[SceneObject]:
        """Visible objects higher than ``goal`` over its position (in the way of filling it)."""
        row = self._above[self._goal_index[goal.id]]
        return [self.scene.objects[j] for j in np.flatnonzero(row)]


def _overlap(
    centre: np.ndarray, half: np.ndarray | float, other: np.ndarray, other_half: np.ndarray
) -> np.ndarray:
    """overlap[i, j]: footprint j (``other`` centres, ``other_half`` half-sizes, (2, K): x
    and y rows) overlaps the one of half-size ``half`` around centre i (``centre``, (2, N))
    by more than ``MARGIN`` along x and y. Both axes in one (2, N, K) pass: half the numpy
    calls of one pass per axis."""
    # A scalar half-size broadcasts as it is (np.broadcast_to costs more than the comparison).
    near = half[:, :, None] if isinstance(half, np.ndarray) else half
    inside = np.abs(other[:, None, :] - centre[:, :, None]) < near + other_half[:, None, :] - MARGIN
    return inside[0] & inside[1]
