"""Can a task's objects fill all its required goals at once? A bipartite matching of goals to
the objects each one accepts, and, when there is none, the goal to name and why. The one
implementation: the sim checks task files with it (``task_attributes``), the planner's
generic expert keeps a maximum matching of what is left to place (``policies.matching``).

Each required goal needs an object of its own (an object fills one goal); which objects a goal
may take is given per goal, as a list or as a bit mask (bit ``i``: object ``i``). A maximum
matching (augmenting paths, Kuhn's method) says whether every goal gets one. When some goal is
left without, the goals reachable from it along alternating paths compete for fewer objects
than there are of them (Hall's condition fails): those goals and objects are what the refusal
names.

**Bounded.** Rows are bit masks, so a step of the search takes the next object not yet seen
in one operation on machine words: each goal's search visits every object at most once, and
the whole matching takes at most ``goals x (2 objects + 1)`` steps (256 x 256 goals and
objects: about 130,000), whatever the file. Goals first take a free object where they have
one, so a file whose goals each have one of their own costs one step a goal.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Shortfall:
    """Goal ``goal`` cannot be filled: ``goals`` (it among them) accept only ``objects``, fewer
    objects than goals."""

    goal: int
    goals: list[int]
    objects: list[int]


@dataclass(frozen=True)
class Matching:
    """For each goal, the object it takes (None: none), the search steps it cost, and the
    first goal no augmenting path reached (None: every goal has an object)."""

    taken: list[int | None]
    steps: int
    failed: int | None = None


def as_masks(admitted: Sequence[Sequence[int]]) -> list[int]:
    """Each goal's objects (a list of indices) as a bit mask."""
    masks = []
    for row in admitted:
        mask = 0
        for item in row:
            mask |= 1 << item
        masks.append(mask)
    return masks


def match(rows: list[int], complete: bool = True) -> Matching:
    """A maximum matching of goals (``rows[g]``: the mask of the objects goal ``g`` accepts).
    ``complete=False`` stops at the first goal left without an object: no matching gives
    every goal one then (a goal an augmenting path misses is missed by every later one), and
    a refused draw costs one failed search, not one per goal left over."""
    owner: dict[int, int] = {}  # object -> goal
    taken: list[int | None] = [None] * len(rows)
    free = 0  # objects some goal accepts and none has taken
    for row in rows:
        free |= row
    steps = 0
    failed: int | None = None
    for start, row in enumerate(rows):  # first, every goal that has a free object takes one
        steps += 1
        if row & free:
            item = _lowest(row & free)
            free &= ~(1 << item)
            owner[item], taken[start] = start, item
    for start in range(len(rows)):
        if taken[start] is not None:
            continue
        if failed is not None and not complete:
            break
        # Depth first along alternating paths: goals[k] reached through items[k - 1].
        goals, items, seen = [start], list[int](), 0
        while goals:
            steps += 1
            goal = goals[-1]
            row = rows[goal] & ~seen
            if not row:  # a dead end: back to the goal before it
                goals.pop()
                if items:
                    items.pop()
                elif failed is None:  # the search from ``start`` is over, with no path
                    failed = start
                continue
            spare = row & free
            item = _lowest(spare or row)
            seen |= 1 << item
            items.append(item)
            if spare:  # an augmenting path: every goal on it takes the next object
                free &= ~(1 << item)
                for g, i in zip(goals, items, strict=True):
                    owner[i], taken[g] = g, i
                break
            goals.append(owner[item])
    return Matching(taken, steps, failed)


def maximum_matching(admitted: list[list[int]]) -> list[int | None]:
    """For each goal (a row of ``admitted``: the objects it accepts), the object it takes in
    a maximum matching, or None."""
    return match(as_masks(admitted)).taken


def matching_size(rows: Sequence[int], banned: int | None = None) -> int:
    """How many goals (``rows[g]``: the mask of the objects goal ``g`` accepts) can take an
    object of their own at once, object ``banned`` left out. Masks, so a caller asking many
    times (the planner's expert: once a candidate move) converts its rows once."""
    if banned is not None:
        keep = ~(1 << banned)
        rows = [row & keep for row in rows]
    return len(rows) - match(list(rows)).taken.count(None)


def shortfall(admitted: list[list[int]]) -> Shortfall | None:
    """None when every goal can take an object of its own at once; else the first goal left
    without one and the goals and objects that compete with it."""
    rows = as_masks(admitted)
    return shortfall_of(rows, match(rows, complete=False))


def shortfall_of(rows: list[int], matching: Matching) -> Shortfall | None:
    """:func:`shortfall` of ``rows`` (masks) given their ``matching`` (complete, or stopped at
    its first failed goal): from that goal, every object reachable along alternating paths is
    taken, by a goal reachable too, so those goals outnumber those objects."""
    owner = {item: goal for goal, item in enumerate(matching.taken) if item is not None}
    if matching.failed is not None:
        goal = matching.failed
        goals, objects = {goal}, 0
        frontier = [goal]
        while frontier:  # alternate: a goal's objects, then the goals owning them
            new = rows[frontier.pop()] & ~objects
            objects |= new
            while new:
                candidate = _lowest(new)
                new &= new - 1
                other = owner.get(candidate)
                if other is not None and other not in goals:
                    goals.add(other)
                    frontier.append(other)
        return Shortfall(goal, sorted(goals), _indices(objects))
    return None


def _lowest(mask: int) -> int:
    """The index of ``mask``'s lowest set bit (``mask`` > 0)."""
    return (mask & -mask).bit_length() - 1


def _indices(mask: int) -> list[int]:
    found = []
    while mask:
        found.append(_lowest(mask))
        mask &= mask - 1
    return found
