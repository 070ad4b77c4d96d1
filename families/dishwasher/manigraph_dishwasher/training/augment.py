"""Dishwasher demonstrations, varied without new expert labels: the same decision shown
with fewer dishes (:func:`drop_dishes`) or more (:func:`add_dishes`) than the demonstration
held, changed only where that cannot change what the expert would do.

The five demonstrations all hold 10 dishes (5 plates, 5 bowls); the policy is tested on 6 to
12. Without more dishes, a network never sees a sixth plate still waiting when five stand
in the rack, and may push the rack in before it (the 12-dish failures of the table).
:func:`add_dishes` is meant against that (``DishTrainConfig.grow_copies``; see
docs/dishwasher.md).
"""

from __future__ import annotations

import random
from dataclasses import dataclass

import torch
from torch import Tensor

from manigraph_dishwasher.fixtures import TrayAction
from manigraph_dishwasher.planner.features import DISH_FEATURE_SPEC, TRAY_ACTIONS

__all__ = ["DishSample", "add_dishes", "counter_dishes", "drop_dishes"]

_NONE = TRAY_ACTIONS.index(TrayAction.NONE)


@dataclass(frozen=True)
class DishSample:
    x: Tensor  # (N, 17)
    num_objects: int
    num_goals: int
    object_index: int  # among the dish nodes (0 for a toggle)
    goal_index: int  # among the slot nodes (0 for a toggle)
    orientation: int  # 0 for a toggle
    tray: int  # index into TRAY_ACTIONS


_FILLED = DISH_FEATURE_SPEC.names.index("filled")
_OPEN = DISH_FEATURE_SPEC.names.index("open")
_XYZ = slice(DISH_FEATURE_SPEC.names.index("x"), DISH_FEATURE_SPEC.names.index("z") + 1)
_Y = DISH_FEATURE_SPEC.names.index("y")
_CATEGORY = slice(0, DISH_FEATURE_SPEC.names.index("x"))
_XY = slice(DISH_FEATURE_SPEC.names.index("x"), _Y + 1)
_XZ = [DISH_FEATURE_SPEC.names.index("x"), DISH_FEATURE_SPEC.names.index("z")]


def drop_dishes(sample: DishSample, rng: random.Random) -> DishSample:
    """A copy of ``sample`` with a random subset of its dishes removed, where that cannot
    change the demonstrated decision: a placement keeps its dish; a toggle that pulls a rack
    out (it is in now) keeps one dish still to load of each kind, as whichever preference
    it serves, that rack is pulled out for one of them; anything else may go. A removed
    dish frees the slot it stood in. This shows the network fewer dishes than the
    demonstrations held, without any further expert label."""
    k = sample.num_objects
    x = sample.x
    keep = [rng.random() < 0.5 for _ in range(k)]
    if sample.tray == _NONE:
        keep[sample.object_index] = True
    elif bool(x[k + sample.num_goals + sample.tray, _OPEN] == 0):  # pulls the rack out
        for kind in (0, 1):  # the plate and bowl one-hot columns
            pending = [i for i in range(k) if x[i, kind] == 1 and x[i, _FILLED] == 0]
            if pending:
                keep[rng.choice(pending)] = True
    if all(keep):
        return sample
    x = x.clone()
    slots = x[k : k + sample.num_goals]
    for i in range(k):
        if not keep[i] and x[i, _FILLED] == 1:
            near = (slots[:, _XYZ] - x[i, _XYZ]).abs().amax(dim=1) < 1e-3
            slots[near, _FILLED] = 0.0
    rows = [i for i in range(k) if keep[i]] + list(range(k, x.shape[0]))
    new_index = sum(keep[: sample.object_index]) if sample.tray == _NONE else 0
    return DishSample(
        x[rows],
        sum(keep),
        sample.num_goals,
        new_index,
        sample.goal_index,
        sample.orientation,
        sample.tray,
    )


_DISH_KINDS = (0, 1)  # the plate and bowl one-hot columns
_SLOT_OF = {0: 2, 1: 3}  # the slot category column each dish kind fills
#: Two nodes this close (metres, on every axis) stand at the same place.
_SAME_PLACE = 1e-3
#: A dish added to the counter keeps at least this far (metres, in x and y) from the others.
_COUNTER_GAP = 0.06


def _pending_kinds(sample: DishSample) -> set[int]:
    """The dish kinds more of which, still on the counter, leave the decision as it is: a
    placement's own kind (it is placed, others of its kind wait); for a toggle that pulls
    a rack out, every kind already waiting (the rack is pulled out for one of them). Never
    for a toggle that pushes a rack in: a dish still to load would keep it out."""
    k, x = sample.num_objects, sample.x
    if sample.tray == _NONE:
        return {int(x[sample.object_index, :2].argmax())}
    if bool(x[k + sample.num_goals + sample.tray, _OPEN] == 0):
        return {c for c in _DISH_KINDS for i in range(k) if x[i, c] == 1 and x[i, _FILLED] == 0}
    return set()


def _free_slots_like_loaded(slots: Tensor, kind: int, keep: int | None) -> list[int]:
    """Free slots (indices into ``slots``, the slot nodes' rows) where a dish of ``kind``
    could stand as the demonstration's own loaded dishes of that kind do: same rack and row
    (the x and z of a filled slot of that kind) and same side (sign of y); never ``keep``
    (a placement's goal)."""
    column = _SLOT_OF[kind]
    mine = slots[:, column] == 1
    filled = slots[mine & (slots[:, _FILLED] == 1)]
    free = []
    for j in range(slots.shape[0]):
        if not mine[j] or slots[j, _FILLED] == 1 or j == keep:
            continue
        row = (filled[:, _XZ] - slots[j, _XZ]).abs().amax(dim=1) < _SAME_PLACE
        side = (filled[:, _Y] > 0) == (slots[j, _Y] > 0)
        if bool((row & side).any()):
            free.append(j)
    return free


def counter_dishes(samples: list[DishSample]) -> dict[int, list[Tensor]]:
    """Every demonstrated dish still on the counter, by kind: where :func:`add_dishes` draws
    its dishes from (a real dish's position, height and orientation)."""
    pool: dict[int, list[Tensor]] = {c: [] for c in _DISH_KINDS}
    for s in samples:
        for i in range(s.num_objects):
            if s.x[i, _FILLED] == 0:
                pool[int(s.x[i, :2].argmax())].append(s.x[i])
    return pool


def add_dishes(
    sample: DishSample, pool: dict[int, list[Tensor]], rng: random.Random, most: int = 3
) -> DishSample:
    """A copy of ``sample`` with up to ``most`` more dishes, where that cannot change the
    demonstrated decision: loaded ones, each in a free slot like those its kind already
    stands in (:func:`_free_slots_like_loaded`; it fills the slot), and waiting ones on the
    counter, of the kinds :func:`_pending_kinds` allows, drawn from ``pool`` (a demonstrated
    dish on the counter) at a place no other dish takes. This shows the network more dishes
    than the demonstrations held (more loaded and more waiting than it ever saw at once),
    without any further expert label."""
    k, x = sample.num_objects, sample.x.clone()
    new_rows: list[Tensor] = []
    waiting = sorted(_pending_kinds(sample))
    for _ in range(rng.randint(1, most)):
        kind = rng.choice(_DISH_KINDS)
        if waiting and rng.random() < 0.5:
            row = _counter_dish(x[:k], new_rows, pool, rng.choice(waiting), rng)
        else:
            row = _loaded_dish(sample, x, kind, rng)
        if row is not None:
            new_rows.append(row)
    if not new_rows:
        return sample
    x = torch.cat([x[:k], torch.stack(new_rows), x[k:]])
    return DishSample(
        x,
        k + len(new_rows),
        sample.num_goals,
        sample.object_index,
        sample.goal_index,
        sample.orientation,
        sample.tray,
    )


def _loaded_dish(sample: DishSample, x: Tensor, kind: int, rng: random.Random) -> Tensor | None:
    """A dish of ``kind`` standing in a free slot like its kind's (:func:`_free_slots_like_loaded`);
    marks that slot filled in ``x`` (the copy being built)."""
    slots = x[sample.num_objects : sample.num_objects + sample.num_goals]
    keep = sample.goal_index if sample.tray == _NONE else None
    free = _free_slots_like_loaded(slots, kind, keep)
    if not free:
        return None
    slot = slots[rng.choice(free)]
    slot[_FILLED] = 1.0
    row = slot.clone()
    row[_CATEGORY] = 0.0
    row[kind] = 1.0
    return row


def _counter_dish(
    dishes: Tensor,
    added: list[Tensor],
    pool: dict[int, list[Tensor]],
    kind: int,
    rng: random.Random,
) -> Tensor | None:
    """A dish of ``kind`` from ``pool`` whose counter place (x, y) no other waiting dish
    takes, or None if 20 draws found none."""
    taken = [d[_XY] for d in [*dishes, *added] if d[_FILLED] == 0]
    for _ in range(20):
        row = rng.choice(pool[kind])
        xy = row[_XY]
        if all(bool((xy - t).abs().amax() >= _COUNTER_GAP) for t in taken):
            return row.clone()
    return None
