"""What the demonstration page draws of a ``Scene``: plain JSON, in metres, in the scene frame.

Every object, goal and rack keeps its id (the page sends ids back, never coordinates). Each
object and goal also gets its **extent**: how far it reaches along the world's x, y and z
axes, its size turned by its orientation, so the page draws a plate standing on its rim as a
thin strip seen from above. A goal has no size in the contract; it is drawn as large as the
objects of its category (a slot as large as the dish it takes).
"""

from __future__ import annotations

import statistics

from manigraph_shared.messages import Quaternion, Scene, SceneObject
from manigraph_shared.orientations import nearest_orientation, up_axis_orientation
from manigraph_shared.rotations import rotation_matrix

#: A goal of a category no object of the scene has (metres): a block's size.
DEFAULT_EXTENT = (0.04, 0.04, 0.04)


def world_extent(size: tuple[float, float, float], q: Quaternion) -> list[float]:
    """Extents along the world axes of a box of ``size`` turned by ``q``."""
    matrix = rotation_matrix(q)
    return [round(float(sum(abs(matrix[i][j]) * size[j] for j in range(3))), 4) for i in range(3)]


def _category_sizes(objects: list[SceneObject]) -> dict[str, tuple[float, float, float]]:
    by_category: dict[str, list[tuple[float, float, float]]] = {}
    for item in objects:
        by_category.setdefault(item.category.value, []).append(item.size.as_tuple())
    return {
        category: (
            statistics.median(s[0] for s in sizes),
            statistics.median(s[1] for s in sizes),
            statistics.median(s[2] for s in sizes),
        )
        for category, sizes in by_category.items()
    }


def _xyz(v: object) -> dict[str, float]:
    x, y, z = v.as_tuple()  # type: ignore[attr-defined]
    return {"x": round(x, 4), "y": round(y, 4), "z": round(z, 4)}


def scene_view(scene: Scene) -> dict[str, object]:
    """The page's view of ``scene`` (see the module docstring)."""
    sizes = _category_sizes(scene.objects)
    objects = [
        {
            "id": item.id,
            "category": item.category.value,
            **_xyz(item.position),
            "extent": world_extent(item.size.as_tuple(), item.orientation),
            # by its up axis: a physical dish keeps its index at any turn about the vertical
            "orientation": up_axis_orientation(item.orientation),
            "filled": item.filled,
            "visible": item.visible,
        }
        for item in scene.objects
    ]
    goals = [
        {
            "id": goal.id,
            "category": goal.category.value,
            **_xyz(goal.position),
            "extent": world_extent(
                sizes.get(goal.category.value, DEFAULT_EXTENT), goal.orientation
            ),
            "orientation": nearest_orientation(goal.orientation),
            "filled": goal.filled,
            "visible": goal.visible,
            "rack": goal.rack,
        }
        for goal in scene.goals
    ]
    racks = [{"id": rack.id, **_xyz(rack.position), "open": rack.open} for rack in scene.racks]
    return {
        "episode_id": scene.episode_id,
        "sequence": scene.sequence,
        "objects": objects,
        "goals": goals,
        "racks": racks,
        "ended": scene.episode_ended,
    }


def same_world(a: Scene | None, b: Scene) -> bool:
    """Whether ``b`` shows what ``a`` showed (only its stamp and sequence differ): the page
    need not be redrawn."""
    return (
        a is not None
        and a.episode_id == b.episode_id
        and a.objects == b.objects
        and a.goals == b.goals
        and a.racks == b.racks
        and a.episode_ended == b.episode_ended
        and a.stale == b.stale
    )
