"""What the demonstration page draws of a ``Scene``: plain JSON, in metres, in the scene frame.

Every object, goal and rack keeps its id (the page sends ids back, never coordinates). Each
object and goal also gets its **extent**: how far it reaches along the world's x, y and z
axes, its size turned by its orientation, so the page draws a plate standing on its rim as a
thin strip seen from above. A goal has no size in the contract; it is drawn as large as the
objects of its category (a slot as large as the dish it takes), or the size it accepts.

A task's attributes come along for the page to draw: an object's ``fill`` is the RGB its
``colour`` attribute names (``#rrggbb``, else null) and its ``label`` its attributes in words
(``colour red, label bolt``); a goal's ``fill`` is the colour it accepts and its ``accepts``
what it accepts in words (empty when it takes any object of its category). ``tag`` is the
values alone (``red, bolt``), written under each on the page.
"""

from __future__ import annotations

import statistics
from collections.abc import Mapping

from manigraph_shared.colours import colour_of, describe
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


def _hex(attributes: Mapping[str, object]) -> str | None:
    rgb = colour_of(attributes)
    return None if rgb is None else "#" + "".join(f"{round(c * 255):02x}" for c in rgb)


def _tag(words: Mapping[str, object]) -> str:
    """The values alone (``red, bolt``), short enough to write under a 4 cm block; a size is
    left out (it is drawn)."""
    return ", ".join(
        f"{value:g}" if isinstance(value, float) else str(value)
        for key, value in words.items()
        if key != "size"
    )


def _accepted_size(accepts: Mapping[str, object]) -> tuple[float, float, float] | None:
    size = accepts.get("size")
    if isinstance(size, list) and len(size) == 3:
        return (float(size[0]), float(size[1]), float(size[2]))
    return None


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
            "fill": _hex(item.attributes),
            "label": describe(item.attributes),
            "tag": _tag(item.attributes),
        }
        for item in scene.objects
    ]
    goals = [
        {
            "id": goal.id,
            "category": goal.category.value,
            **_xyz(goal.position),
            "extent": world_extent(
                _accepted_size(goal.accepts) or sizes.get(goal.category.value, DEFAULT_EXTENT),
                goal.orientation,
            ),
            "orientation": nearest_orientation(goal.orientation),
            "filled": goal.filled,
            "visible": goal.visible,
            "fixture": goal.fixture,
            "fill": _hex(goal.accepts),
            "accepts": describe(goal.accepts),
            "tag": _tag(goal.accepts),
        }
        for goal in scene.goals
    ]
    # A fixture's state beside its position (``open`` of a rack): what the page draws it by;
    # its extents where its family gives it a size (a board or a wall is drawn as its box).
    fixtures = [
        {
            **fixture.state,
            "id": fixture.id,
            "kind": fixture.kind,
            **_xyz(fixture.position),
            "extent": None
            if fixture.size is None
            else world_extent(fixture.size.as_tuple(), fixture.orientation),
        }
        for fixture in scene.fixtures
    ]
    return {
        "episode_id": scene.episode_id,
        "sequence": scene.sequence,
        "objects": objects,
        "goals": goals,
        "fixtures": fixtures,
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
        and a.fixtures == b.fixtures
        and a.episode_ended == b.episode_ended
        and a.stale == b.stale
    )
