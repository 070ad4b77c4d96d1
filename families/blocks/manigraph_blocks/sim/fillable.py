"""Which objects may fill each goal: one look-up per key a goal accepts, in an index of the
distinct values objects may carry.

A goal admits an object when every key of its ``accepts`` matches (``manigraph_shared.
acceptance``: text equal, numbers within 1e-9, ``size`` within 1 mm on each axis, ``id`` the
object itself); before any draw, an object may carry any value of its list, and any value of
the pool of a ``shuffle``d attribute. Asking ``admits`` of every goal, object and value costs
goals x objects x values: a 60 KB file of 130 objects listing 64 values each, shuffled, and
goals accepting a value none has, was 140 million comparisons (minutes of the sim's thread).

Here the values are indexed once, each distinct value with the mask of the objects that may
carry it (a shuffled attribute's pool is one list shared by its carriers, indexed once), and a
goal's row is the AND of one look-up per key: the cost is the file's values once, plus goals x
keys look-ups, whatever the duplicates.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np

from manigraph_shared.acceptance import SIZE_TOLERANCE

AttributeValue = str | float
#: Numbers match within this (``manigraph_shared.acceptance``).
NUMBER_TOLERANCE = 1e-9


class Fillable(Protocol):
    """What the index reads of an object (``task_attributes.Candidate``)."""

    @property
    def id(self) -> str: ...
    @property
    def category(self) -> str: ...
    @property
    def size(self) -> tuple[float, float, float]: ...
    @property
    def values(self) -> Mapping[str, Sequence[AttributeValue]]: ...
    @property
    def spare(self) -> bool: ...


class Accepting(Protocol):
    """What the index reads of a goal (``task_attributes.Wanted``)."""

    @property
    def category(self) -> str: ...
    @property
    def accepts(self) -> Mapping[str, AttributeValue | Sequence[float]]: ...


class ValueIndex:
    """One attribute's distinct values, each with the mask of the objects that may carry it."""

    def __init__(self) -> None:
        self.text: dict[str, int] = {}
        self._numbers: dict[float, int] = {}
        self._sorted: list[float] | None = None

    def add(self, values: Sequence[AttributeValue], mask: int) -> None:
        for value in values:
            if isinstance(value, str):
                self.text[value] = self.text.get(value, 0) | mask
            else:
                number = float(value)
                self._numbers[number] = self._numbers.get(number, 0) | mask
        self._sorted = None

    def carriers(self, wanted: object) -> int:
        """The objects that may carry ``wanted`` (text equal, a number within 1e-9)."""
        if isinstance(wanted, str):
            return self.text.get(wanted, 0)
        if not isinstance(wanted, int | float) or isinstance(wanted, bool):
            return 0
        if self._sorted is None:
            self._sorted = sorted(self._numbers)
        low = bisect_left(self._sorted, float(wanted) - NUMBER_TOLERANCE)
        high = bisect_right(self._sorted, float(wanted) + NUMBER_TOLERANCE)
        mask = 0
        for number in self._sorted[low:high]:  # one, unless numbers differ by under 2e-9
            if abs(number - float(wanted)) <= NUMBER_TOLERANCE:
                mask |= self._numbers[number]
        return mask


def fillable_rows(goals: Sequence[Accepting], objects: Sequence[Fillable]) -> list[int]:
    """For each goal, the mask (bit ``i``: ``objects[i]``) of the objects that are not spares
    and that some draw lets fill it."""
    categories: dict[str, int] = {}
    ids: dict[str, int] = {}
    indexes: dict[str, ValueIndex] = {}
    shared: dict[tuple[str, int], int] = {}  # (attribute, id of a shared list) -> carriers
    lists: dict[int, Sequence[AttributeValue]] = {}
    usable = [i for i, item in enumerate(objects) if not item.spare]
    for i in usable:
        item, bit = objects[i], 1 << i
        categories[item.category] = categories.get(item.category, 0) | bit
        ids[item.id] = ids.get(item.id, 0) | bit
        for name, values in item.values.items():
            shared_key = (name, id(values))
            shared[shared_key] = shared.get(shared_key, 0) | bit
            lists[id(values)] = values
    for (name, list_id), mask in shared.items():  # a list shared by many is indexed once
        indexes.setdefault(name, ValueIndex()).add(lists[list_id], mask)
    sizes = np.array([objects[i].size for i in usable], dtype=float).reshape(-1, 3)
    looked_up: dict[tuple[str, object], int] = {}

    def carriers(key: str, wanted: AttributeValue | Sequence[float]) -> int:
        if key == "id":
            return ids.get(wanted, 0) if isinstance(wanted, str) else 0
        if key == "size":
            if isinstance(wanted, str | int | float) or len(wanted) != 3:
                return 0
            close = np.all(np.abs(sizes - np.array(wanted, dtype=float)) <= SIZE_TOLERANCE, axis=1)
            return sum(1 << usable[int(n)] for n in np.flatnonzero(close))
        index = indexes.get(key)
        return 0 if index is None else index.carriers(wanted)

    rows = []
    for goal in goals:
        row = categories.get(goal.category, 0)
        for key, wanted in goal.accepts.items():
            if not row:
                break
            memo = (key, wanted if isinstance(wanted, str | int | float) else tuple(wanted))
            if memo not in looked_up:
                looked_up[memo] = carriers(key, wanted)
            row &= looked_up[memo]
        rows.append(row)
    return rows
