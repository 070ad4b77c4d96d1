"""Node feature columns a task brings: sizes, attributes, and what goals accept.

A policy trained on a task file whose objects carry ``attributes`` (``colour = "red"``) or
whose goals list what they ``accepts`` (``colour = "red"``, ``id = "part_2"``, ``size =
[0.03, 0.03, 0.03]``) sees, after the paper's five columns (:mod:`.features`):

* ``size_x, size_y, size_z``: an object's full extents; on a goal, the extents it accepts
  (zero when it accepts any size); in decimetres (``size_scale``), like a block's 0.4;
* ``size:any``: 1 on a goal that accepts any size, else 0;
* per categorical attribute (``colour``), one column per value of its vocabulary
  (``colour=blue``, ``colour=red``): an object's value one-hot, a goal's accepted value
  one-hot; then ``colour:any``, 1 on a goal that does not ask for a colour. An object
  without the attribute has zeros. ``id`` is a categorical attribute whose vocabulary is the
  ids goals accept (an object whose id no goal names has zeros);
* per numeric attribute (``weight``): its value scaled to ``(value - offset) / span`` (the
  demonstrations' range maps to [0, 1]), then ``weight:any``.

* per attribute some goal itself carries (``attributes = { colour = "red" }`` on a goal: a
  bin's colour, a rack's side), after all of the above: ``goal.colour=blue``,
  ``goal.colour=red`` (the same vocabulary as ``colour``'s), or ``goal.weight`` scaled alike:
  the goal's own value, as an object's value is the object's; zeros on objects and on goals
  without it. These columns are not part of what a goal accepts (:meth:`TaskFeatures.admits`).
* with ``goal_support`` (learned where some goal stands on another: a tower, a pyramid), last:
  ``goal:ready``, 1 on a goal that can be filled now (free, every goal under it filled:
  :mod:`.goal_support`), 0 on other goals and on objects. A tower taller than taught then
  still shows which level is next, where absolute heights never seen do not (issue #49).
  A checkpoint without ``goal_support`` in its stamp reads exactly the columns it was trained
  on.

What the columns are is learned from the demonstrations' scenes (:meth:`TaskFeatures.learn`)
and stamped in the checkpoint (``feature_spec.task``). A text value outside a categorical
vocabulary (a stone distractor where training saw only red and blue) reads as *other*: zeros
in that attribute's value columns, what an object without the attribute shows, and one
warning per attribute and value (logger ``manigraph_planner.gnn.task_features``); a goal
asking for such a value admits nothing. A goal asking by a key the policy never saw, or a
number where the policy knows words (or the reverse), is refused with a
:class:`~manigraph_shared.errors.PolicyError` naming both.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import torch
from torch import Tensor

from manigraph_planner.gnn.goal_support import READY_COLUMN, stands_on_goals
from manigraph_shared.acceptance import SIZE_TOLERANCE
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import Scene, SceneGoal, SceneObject

__all__ = ["GOAL_PREFIX", "SIZE_SCALE", "AttributeColumns", "TaskFeatures", "goal_attributes_of"]

_log = logging.getLogger(__name__)
#: (attribute, value) pairs already warned about as "other": one warning each per process.
_WARNED_OTHER: set[tuple[str, str]] = set()
#: Prefix of the columns of a goal's own attributes (not a character an attribute name has).
GOAL_PREFIX = "goal."

#: Size columns are in decimetres: a 4 cm block reads 0.4, beside positions in metres.
SIZE_SCALE = 10.0
SIZE_COLUMNS = ("size_x", "size_y", "size_z", "size:any")
#: Sizes are compared in float32 columns: this much (decimetres) of rounding is no size gap.
#: The tolerance itself is the judge's, ``manigraph_shared.acceptance.SIZE_TOLERANCE``.
FLOAT32_SLACK = 1e-5


@dataclass(frozen=True)
class AttributeColumns:
    """The columns of one attribute: a categorical ``vocabulary`` (sorted), or numeric with
    its ``offset`` and ``span``."""

    name: str
    vocabulary: tuple[str, ...] = ()
    numeric: bool = False
    offset: float = 0.0
    span: float = 1.0

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("attributes.name: must be non-empty")
        if self.numeric and self.vocabulary:
            raise ValueError(f"attributes.{self.name}: numeric, so it has no vocabulary")
        if not self.numeric and len(set(self.vocabulary)) != len(self.vocabulary):
            raise ValueError(f"attributes.{self.name}.vocabulary: values must be unique")
        if not (math.isfinite(self.offset) and math.isfinite(self.span) and self.span > 0):
            raise ValueError(f"attributes.{self.name}: offset finite and span > 0")

    @property
    def columns(self) -> tuple[str, ...]:
        if self.numeric:
            return (self.name, f"{self.name}:any")
        return (*(f"{self.name}={value}" for value in self.vocabulary), f"{self.name}:any")

    def object_cells(self, obj: SceneObject) -> list[float]:
        """The object's value (zeros without one; an id outside the vocabulary too)."""
        value = obj.id if self.name == "id" else obj.attributes.get(self.name)
        if value is None or (self.name == "id" and value not in self.vocabulary):
            return [0.0] * len(self.columns)
        return [*self._cells(value, f"{obj.id} {self.name}"), 0.0]

    def goal_cells(self, goal: SceneGoal) -> list[float]:
        """The value the goal accepts, or zeros and the ``any`` flag."""
        value = goal.accepts.get(self.name)
        if value is None:
            return [*([0.0] * (len(self.columns) - 1)), 1.0]
        if isinstance(value, list):
            raise PolicyError(
                f"scene: goal {goal.id} accepts {self.name} {value}, a list; this policy "
                f"knows {self.name} as {'a number' if self.numeric else 'a word'}"
            )
        return [*self._cells(value, f"goal {goal.id} accepts {self.name}"), 0.0]

    def _cells(self, value: str | float, who: str) -> list[float]:
        if self.numeric:
            if isinstance(value, str):
                raise PolicyError(f"scene: {who} {value!r} is text; this policy knows numbers")
            return [(float(value) - self.offset) / self.span]
        if not isinstance(value, str):
            raise PolicyError(f"scene: {who} {value!r} is a number; this policy knows words")
        if value not in self.vocabulary and (self.name, value) not in _WARNED_OTHER:
            _WARNED_OTHER.add((self.name, value))
            _log.warning(
                "scene: %s %r is not in this policy's vocabulary (%s): read as other",
                who,
                value,
                ", ".join(self.vocabulary),
            )
        return [1.0 if value == known else 0.0 for known in self.vocabulary]

    @property
    def goal_columns(self) -> tuple[str, ...]:
        """The columns of a goal's own value of this attribute (``goal.colour=red``)."""
        return tuple(GOAL_PREFIX + column for column in self.columns[:-1])

    def own_cells(self, attributes: Mapping[str, str | float], who: str) -> list[float]:
        """A goal's own value (zeros without one), in :attr:`goal_columns`."""
        value = attributes.get(self.name)
        if value is None:
            return [0.0] * len(self.goal_columns)
        return self._cells(value, f"{who} {self.name}")

    def to_dict(self) -> dict[str, Any]:
        if self.numeric:
            return {"name": self.name, "offset": self.offset, "span": self.span}
        return {"name": self.name, "vocabulary": list(self.vocabulary)}

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> AttributeColumns:
        if not isinstance(values, dict) or not isinstance(values.get("name"), str):
            raise ValueError("attributes: each entry needs a 'name'")
        name = values["name"]
        if "vocabulary" in values:
            vocabulary = values["vocabulary"]
            if not isinstance(vocabulary, list | tuple) or not all(
                isinstance(v, str) for v in vocabulary
            ):
                raise ValueError(f"attributes.{name}.vocabulary: must be a list of words")
            return cls(name, tuple(vocabulary))
        try:
            return cls(
                name, numeric=True, offset=float(values["offset"]), span=float(values["span"])
            )
        except (KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, ValueError) and str(exc).startswith("attributes."):
                raise
            raise ValueError(f"attributes.{name}: needs a vocabulary, or offset and span") from None


@dataclass(frozen=True)
class TaskFeatures:
    """The columns a task adds after the paper's five (see the module docstring)."""

    attributes: tuple[AttributeColumns, ...] = ()
    size_scale: float = SIZE_SCALE
    #: Names of the attributes goals themselves carry (sorted; each one of ``attributes``).
    goal_attributes: tuple[str, ...] = ()
    #: The ``goal:ready`` column last (:mod:`.goal_support`); False in every older stamp.
    goal_support: bool = False

    def __post_init__(self) -> None:
        names = [a.name for a in self.attributes]
        if len(set(names)) != len(names) or "size" in names:
            raise ValueError(f"attributes: names must be unique and not 'size', got {names}")
        if not (math.isfinite(self.size_scale) and self.size_scale > 0):
            raise ValueError("size_scale: must be a positive number")
        if list(self.goal_attributes) != sorted(set(self.goal_attributes)) or not set(
            self.goal_attributes
        ) <= set(names) - {"id"}:
            raise ValueError(
                f"goal_attributes: sorted names of attributes ({', '.join(names)}), "
                f"got {list(self.goal_attributes)}"
            )

    @property
    def _goal_owned(self) -> tuple[AttributeColumns, ...]:
        return tuple(a for a in self.attributes if a.name in self.goal_attributes)

    @property
    def names(self) -> tuple[str, ...]:
        return (
            *SIZE_COLUMNS,
            *(column for a in self.attributes for column in a.columns),
            *(column for a in self._goal_owned for column in a.goal_columns),
            *((READY_COLUMN,) if self.goal_support else ()),
        )

    def object_row(self, obj: SceneObject) -> list[float]:
        size = [extent * self.size_scale for extent in obj.size.as_tuple()]
        own = [0.0 for a in self._goal_owned for _ in a.goal_columns]
        return [
            *size,
            0.0,
            *(cell for a in self.attributes for cell in a.object_cells(obj)),
            *own,
            *((0.0,) if self.goal_support else ()),
        ]

    def goal_row(self, goal: SceneGoal, ready: bool = False) -> list[float]:
        """The goal's columns; ``ready``: it can be filled now (read with ``goal_support``)."""
        self._check_keys(goal)
        size = goal.accepts.get("size")
        if isinstance(size, list):
            cells = [float(extent) * self.size_scale for extent in size] + [0.0]
        elif size is None:
            cells = [0.0, 0.0, 0.0, 1.0]
        else:
            raise PolicyError(f"scene: goal {goal.id} accepts size {size!r}, not [x, y, z]")
        carried = goal_attributes_of(goal)
        return [
            *cells,
            *(cell for a in self.attributes for cell in a.goal_cells(goal)),
            *(cell for a in self._goal_owned for cell in a.own_cells(carried, f"goal {goal.id}")),
            *((float(ready),) if self.goal_support else ()),
        ]

    def _check_keys(self, goal: SceneGoal) -> None:
        known = {"size", *(a.name for a in self.attributes)}
        for key in goal.accepts:
            if key not in known:
                raise PolicyError(
                    f"scene: goal {goal.id} accepts by {key!r}, which this policy was not "
                    f"trained on (it knows {', '.join(sorted(known))})"
                )

    def admits(self, objects: Tensor, goals: Tensor) -> Tensor:
        """``admits[k, l]``: goal node ``l`` accepts object node ``k``, read off the task
        columns alone (``accepts`` as ``manigraph_shared.acceptance`` matches it: every
        attribute a goal asks for equal, sizes within ``SIZE_TOLERANCE``, the judge's 1 mm);
        categories are not checked.

        Shapes:
            - **objects:** :math:`(K, F)`, **goals:** :math:`(L, F)`: graph state rows
            - **output:** :math:`(K, L)` bool
        """
        ok = torch.ones(objects.shape[0], goals.shape[0], dtype=torch.bool)
        start = 5
        size_tolerance = SIZE_TOLERANCE * self.size_scale + FLOAT32_SLACK
        gap = (objects[:, None, start : start + 3] - goals[None, :, start : start + 3]).abs()
        ok &= (goals[None, :, start + 3] > 0.5) | (gap <= size_tolerance).all(dim=2)
        start += len(SIZE_COLUMNS)
        for attribute in self.attributes:
            width = len(attribute.columns)
            have = objects[:, start : start + width - 1]
            want = goals[:, start : start + width - 1]
            any_value = goals[None, :, start + width - 1] > 0.5
            if attribute.numeric:
                same = (have[:, None, 0] - want[None, :, 0]).abs() <= 1e-6
            else:
                same = (have @ want.T) > 0.5
            ok &= any_value | same
            start += width
        return ok

    def to_dict(self) -> dict[str, Any]:
        values: dict[str, Any] = {
            "size_scale": self.size_scale,
            "attributes": [a.to_dict() for a in self.attributes],
        }
        if self.goal_attributes:  # a stamp without goal attributes stays what it was
            values["goal_attributes"] = list(self.goal_attributes)
        if self.goal_support:  # likewise without the ready column
            values["goal_support"] = True
        return values

    @classmethod
    def from_dict(cls, values: Any) -> TaskFeatures:
        """Raises ``ValueError`` naming the field (below ``task``)."""
        if not isinstance(values, dict):
            raise ValueError("task: must be a table")
        known = {"size_scale", "attributes", "goal_attributes", "goal_support"}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"task.{unknown[0]}: unexpected key")
        attributes = values.get("attributes", [])
        if not isinstance(attributes, list | tuple):
            raise ValueError("task.attributes: must be a list")
        owned = values.get("goal_attributes", [])
        if not isinstance(owned, list | tuple) or not all(isinstance(n, str) for n in owned):
            raise ValueError("task.goal_attributes: must be a list of names")
        support = values.get("goal_support", False)
        if not isinstance(support, bool):
            raise ValueError("task.goal_support: must be true or false")
        try:
            scale = float(values.get("size_scale", SIZE_SCALE))
            return cls(
                tuple(AttributeColumns.from_dict(a) for a in attributes),
                scale,
                tuple(owned),
                support,
            )
        except (TypeError, ValueError) as exc:
            raise ValueError(f"task.{exc}") from None

    @classmethod
    def learn(cls, scenes: Iterable[Scene]) -> TaskFeatures | None:
        """The columns the scenes' attributes and accepts need; None when no object or goal
        carries an attribute, no goal lists what it accepts and the objects of each category
        are all of one size (the paper's five columns then). ``goal_support`` is on where
        some goal stands on another (a tower).

        Raises:
            ValueError: an attribute is text on one object and a number on another.
        """
        values: dict[str, list[str | float]] = {}
        ids: set[str] = set()
        owned: set[str] = set()
        sizes: dict[str, set[tuple[float, ...]]] = {}
        seen = False
        stacked = False
        for scene in scenes:
            stacked = stacked or stands_on_goals(scene)
            for obj in scene.objects:
                seen = seen or bool(obj.attributes)
                sizes.setdefault(str(obj.category), set()).add(
                    tuple(round(extent, 4) for extent in obj.size.as_tuple())
                )
                for name, value in obj.attributes.items():
                    values.setdefault(name, []).append(value)
            for goal in scene.goals:
                carried = goal_attributes_of(goal)
                seen = seen or bool(goal.accepts) or bool(carried)
                for name, value in carried.items():
                    owned.add(name)
                    values.setdefault(name, []).append(value)
                for name, accepted in goal.accepts.items():
                    if name == "id" and isinstance(accepted, str):
                        ids.add(accepted)
                    elif name != "size" and not isinstance(accepted, list):
                        values.setdefault(name, []).append(accepted)
        # Objects of one category in several sizes: the size columns let a rule nobody
        # wrote be read off sizes (big flat ones to the back row, largest at the bottom).
        seen = seen or any(len(found) > 1 for found in sizes.values())
        if not seen:
            return None
        columns = [_columns(name, found) for name, found in sorted(values.items())]
        if ids:
            columns.append(AttributeColumns("id", tuple(sorted(ids))))
        return cls(tuple(columns), goal_attributes=tuple(sorted(owned)), goal_support=stacked)


def goal_attributes_of(goal: SceneGoal) -> Mapping[str, str | float]:
    """The goal's own attributes (``SceneGoal.attributes``: a bin's colour)."""
    return goal.attributes


def _columns(name: str, values: list[str | float]) -> AttributeColumns:
    words = [v for v in values if isinstance(v, str)]
    if words and len(words) != len(values):
        raise ValueError(f"attribute {name}: text on some objects or goals, numbers on others")
    if words:
        return AttributeColumns(name, tuple(sorted(set(words))))
    numbers = [float(v) for v in values]
    low, high = min(numbers), max(numbers)
    return AttributeColumns(name, numeric=True, offset=low, span=high - low if high > low else 1.0)
