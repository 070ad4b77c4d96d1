"""Geometric relations read off a Scene (what rests on what)."""

from __future__ import annotations

from manigraph_shared.messages import Scene, SceneObject

MARGIN = 0.002


def is_covered(scene: Scene, item: SceneObject) -> bool:
    """Another object rests on top of ``item`` (overlapping footprint, above its top)."""
    top = item.position.z + item.size.z / 2
    for other in scene.objects:
        if other.id == item.id:
            continue
        bottom = other.position.z - other.size.z / 2
        overlap_x = (
            abs(other.position.x - item.position.x) < (other.size.x + item.size.x) / 2 - MARGIN
        )
        overlap_y = (
            abs(other.position.y - item.position.y) < (other.size.y + item.size.y) / 2 - MARGIN
        )
        if overlap_x and overlap_y and bottom >= top - MARGIN:
            return True
    return False
