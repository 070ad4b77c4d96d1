"""The shelf's scripted expert: every back slot before any front slot.

A back slot is reachable only while the front slot before it is free, so the expert fills
all back slots first, then the front ones. Filling every back slot first (rather than column
by column) is also a rule a learned policy can read off the whole scene: "a free back slot
is left" is one fact about the graph, not a pairing of each front slot with the slot behind
it. Among the slots of a row, and among the blocks still on the table, it takes one drawn by
a hash of episode and ids: deterministic, yet over demonstrations every slot and block is
shown, so a policy learns "any free back slot" rather than one order it cannot extend.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence
from typing import TypeVar

from manigraph_planner.policies.base import Decision, Policy, register_policy
from manigraph_shared.messages import Scene, SceneGoal, SceneObject
from manigraph_shelf.shelf_geometry import BACK, FRONT, ROW_ATTRIBUTE

_T = TypeVar("_T", SceneGoal, SceneObject)


def _in_drawn_order(items: Sequence[_T], key: str) -> list[_T]:
    return sorted(items, key=lambda item: (zlib.crc32((key + item.id).encode()), item.id))


@register_policy("shelf-expert")
class ShelfExpert(Policy):
    """A block still on the table (not in a slot) into a free back slot while one is left,
    then into a free front slot; nothing once every slot is filled."""

    def decide(self, scene: Scene) -> Decision | None:
        ranked = self.ranked(scene)
        return ranked[0] if ranked else None

    def ranked(self, scene: Scene) -> list[Decision]:
        """Every block still on the table into every free slot of the row being filled (back
        while one is free): the drawn slot with each block in drawn order first, then the next
        slot. A refused pick (no grasp for that block where it lies, the commonest refusal in
        physics) is followed by another block for the same slot; never by a front slot while a
        back one is free, which would block it."""
        loose = [obj for obj in scene.objects if not obj.filled]
        if not loose:
            return []
        for row in (BACK, FRONT):
            free = [
                goal
                for goal in scene.goals
                if not goal.filled and goal.attributes.get(ROW_ATTRIBUTE) == row
            ]
            if free:
                key = f"{scene.episode_id}/{len(loose)}/"
                blocks = _in_drawn_order(loose, key)
                return [
                    Decision(block.id, slot.id)
                    for slot in _in_drawn_order(free, key)
                    for block in blocks
                ]
        return []
