"""Can a task's objects fill all its required goals at once? A bipartite matching of goals to
the objects each one accepts, and, when there is none, the goal to name and why.

Each required goal needs an object of its own (an object fills one goal); which objects a goal
may take is given as a list per goal. A maximum matching (augmenting paths, Kuhn's method)
says whether every goal gets one. When some goal is left without, the goals reachable from it
along alternating paths compete for fewer objects than there are of them (Hall's condition
fails): those goals and objects are what the refusal names.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Shortfall:
    """Goal ``goal`` cannot be filled: ``goals`` (it among them) accept only ``objects``, fewer
    objects than goals."""

    goal: int
    goals: list[int]
    objects: list[int]


def maximum_matching(admitted: list[list[int]]) -> list[int | None]:
    """For each goal (a row of ``admitted``: the objects it accepts), the object it takes in
    a maximum matching, or None."""
    owner: dict[int, int] = {}  # object -> goal

    def augment(goal: int, seen: set[int]) -> bool:
        for item in admitted[goal]:
            if item in seen:
                continue
            seen.add(item)
            if item not in owner or augment(owner[item], seen):
                owner[item] = goal
                return True
        return False

    for goal in range(len(admitted)):
        augment(goal, set())
    taken: list[int | None] = [None] * len(admitted)
    for item, goal in owner.items():
        taken[goal] = item
    return taken


def shortfall(admitted: list[list[int]]) -> Shortfall | None:
    """None when every goal can take an object of its own at once; else the first goal left
    without one and the goals and objects that compete with it."""
    taken = maximum_matching(admitted)
    owner = {item: goal for goal, item in enumerate(taken) if item is not None}
    for goal, item in enumerate(taken):
        if item is not None:
            continue
        goals, objects = [goal], set()
        frontier = [goal]
        while frontier:  # alternate: a goal's objects, then the goals owning them
            row = frontier.pop()
            for candidate in admitted[row]:
                if candidate in objects:
                    continue
                objects.add(candidate)
                other = owner.get(candidate)
                if other is not None and other not in goals:
                    goals.append(other)
                    frontier.append(other)
        return Shortfall(goal, sorted(goals), sorted(objects))
    return None
