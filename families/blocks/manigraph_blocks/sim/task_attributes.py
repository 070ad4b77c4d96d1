"""A task file's attributes and what its goals accept: drawing them per episode, and checking
that the objects can fill every required goal.

An object's attribute is a value (``colour = "red"``) or a list of values to draw one from per
episode (``colour = ["red", "blue"]``); a file-level ``shuffle = ["colour"]`` then permutes the
drawn values of that attribute among the objects that carry it. Both are drawn from the
episode's seed, after the positions (a file without draws keeps its layouts).

Before any episode, a file whose required goals cannot all be filled at once by objects that
are not spares, whatever the draws give, is refused naming a goal; a draw whose values leave a
goal without an object is drawn again (up to :data:`MAX_DRAWS` times, still from the seed).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from difflib import get_close_matches

import numpy as np

from manigraph_blocks.sim.fillable import fillable_rows
from manigraph_blocks.sim.task_file_specs import RESERVED, GoalSpec, ObjectSpec
from manigraph_shared.errors import DrawRefused
from manigraph_shared.goal_matching import Shortfall, match, shortfall_of
from manigraph_shared.printable import quoted

AttributeValue = str | float
#: Draws of a file's attributes tried per episode before the episode is refused.
MAX_DRAWS = 100
#: Ids named in one refusal before "..." .
NAMES_SHOWN = 5


@dataclass(frozen=True)
class Candidate:
    """What one object may carry in some draw: each attribute's possible values."""

    id: str
    category: str
    size: tuple[float, float, float]
    values: Mapping[str, Sequence[AttributeValue]]
    spare: bool


@dataclass(frozen=True)
class Wanted:
    """A required goal: what it is, where it is listed, what it accepts."""

    index: int  # in the file's goals
    id: str
    category: str
    accepts: Mapping[str, AttributeValue | Sequence[float]]


def first_shortfall(goals: list[Wanted], objects: list[Candidate]) -> tuple[Shortfall, str] | None:
    """The goal that objects which are not spares cannot fill, with why; None if they can
    fill every goal at once. The cheapest check first: a goal no object may fill alone is
    named before any matching is tried."""
    missing = _shortfall(goals, objects)
    if missing is None:
        return None
    goal = goals[missing.goal]
    wants = describe(goal.accepts) or f"any {goal.category}"
    if not missing.objects:
        why = f"it accepts {wants}, and no object that is not a spare can be that"
    else:
        rivals = [goals[g].id for g in missing.goals]
        takers = [objects[i].id for i in missing.objects]
        why = (
            f"it accepts {wants}; {len(rivals)} required goals ({names(rivals)}) share the "
            f"{len(takers)} object{'s' if len(takers) != 1 else ''} that can fill them "
            f"({names(takers)}), spares left out"
        )
    return missing, f"goals.{goal.index}: {goal.id} cannot be filled: {why}"


def _shortfall(goals: list[Wanted], objects: list[Candidate]) -> Shortfall | None:
    rows = fillable_rows(goals, objects)
    for index, row in enumerate(rows):
        if not row:
            return Shortfall(index, [index], [])
    return shortfall_of(rows, match(rows, complete=False))


def required(
    goals: Sequence[GoalSpec],
    same: Sequence[str] = (),
    drawn: Sequence[Mapping[str, AttributeValue]] | None = None,
    shuffle: Sequence[str] = (),
) -> list[Wanted]:
    """The goals that must be filled, as the matching sees them: each one's ``accepts``, and
    under ``same`` its own value of those attributes (``drawn``: this episode's values; left
    out, the values that are certain before a draw: a single value not in ``shuffle``)."""
    wanted = []
    for i, goal in enumerate(goals):
        if goal.optional:
            continue
        own = drawn[i] if drawn is not None else _certain(goal.attributes, shuffle)
        wanted.append(Wanted(i, goal.id, goal.category, same_accepts(goal.accepts, own, same)))
    return wanted


def same_accepts(
    accepts: Mapping[str, AttributeValue | Sequence[float]],
    attributes: Mapping[str, AttributeValue],
    same: Sequence[str],
) -> dict[str, AttributeValue | Sequence[float]]:
    """A goal's ``accepts`` with, for each attribute named in ``same`` that the goal carries,
    its own value (a key the goal's ``accepts`` lists itself stays as listed)."""
    merged = {name: attributes[name] for name in same if name in attributes}
    return merged | dict(accepts)


def _certain(
    attributes: Mapping[str, AttributeValue | Sequence[AttributeValue]], shuffle: Sequence[str]
) -> dict[str, AttributeValue]:
    return {
        k: v for k, v in attributes.items() if isinstance(v, str | int | float) and k not in shuffle
    }


def candidates(objects: Sequence[ObjectSpec], shuffle: Sequence[str]) -> list[Candidate]:
    """The objects as the matching sees them, each attribute with every value a draw may
    give it."""
    possible = possible_values([o.attributes for o in objects], shuffle, [o.spare for o in objects])
    return [
        Candidate(o.id, o.category, o.size, values, o.spare)
        for o, values in zip(objects, possible, strict=True)
    ]


def unknown_attributes(
    objects: Sequence[ObjectSpec], goals: Sequence[GoalSpec], shuffle: Sequence[str]
) -> list[str]:
    """Goals accepting, or a shuffle naming, an attribute no object carries (with the name
    probably meant), and goals accepting an id no object has."""
    carried = sorted({name for o in objects for name in o.attributes})
    ids = {o.id for o in objects}

    def unknown(field: str, name: str) -> str:
        close = get_close_matches(name, carried, n=1, cutoff=0.6)
        hint = f"; did you mean {close[0]}?" if close else ""
        return f"{field}: no object carries an attribute {name}{hint}"

    problems = []
    for i, goal in enumerate(goals):
        for key, value in goal.accepts.items():
            if key == "id" and value not in ids:
                problems.append(f"goals.{i}.accepts.id: {goal.id} accepts {value}: no such object")
            elif key not in RESERVED and key not in carried:
                problems.append(unknown(f"goals.{i}.accepts.{key}", key))
    goal_carried = {name for g in goals for name in g.attributes}
    problems += [
        unknown(f"shuffle.{i}", n)
        for i, n in enumerate(shuffle)
        if n not in carried and n not in goal_carried
    ]
    return problems


def unknown_same(
    objects: Sequence[ObjectSpec], goals: Sequence[GoalSpec], same: Sequence[str], field: str
) -> list[str]:
    """Names in ``same`` (at ``field``) that no goal, or no object, carries."""
    problems = []
    for i, name in enumerate(same):
        if not any(name in g.attributes for g in goals):
            problems.append(f"{field}.{i}: no goal carries an attribute {name}")
        elif not any(name in o.attributes for o in objects):
            problems.append(f"{field}.{i}: no object carries an attribute {name}")
    return problems


def episode_attributes(
    rng: np.random.Generator,
    objects: Sequence[ObjectSpec],
    goals: Sequence[GoalSpec],
    shuffle: Sequence[str],
    same: Sequence[str] = (),
) -> tuple[list[dict[str, AttributeValue]], list[dict[str, AttributeValue]]]:
    """Each object's and each goal's attributes for one episode: drawn (:func:`draw`, the
    objects' then the goals') until the objects that are not spares can fill every required
    goal, at most :data:`MAX_DRAWS` times. Goals are drawn only where some goal has a draw,
    so a file without one lays out as before goals carried attributes."""
    listed = [o.attributes for o in objects]
    spares = [o.spare for o in objects]
    goal_listed = [g.attributes for g in goals]
    drawing = bool(shuffle) or any(not _single(v) for a in listed for v in a.values())
    goals_drawing = any(not _single(v) for a in goal_listed for v in a.values()) or any(
        name in a for a in goal_listed for name in shuffle
    )
    if not drawing and not goals_drawing:  # no draw: single values
        return (
            [{k: _one_of(rng, v) for k, v in a.items()} for a in listed],
            [{k: _one_of(rng, v) for k, v in a.items()} for a in goal_listed],
        )
    missing = None
    for _ in range(MAX_DRAWS):
        drawn = draw(rng, listed, shuffle, spares)
        drawn_goals = (
            draw(rng, goal_listed, shuffle)
            if goals_drawing
            else [{k: _one_of(rng, v) for k, v in a.items()} for a in goal_listed]
        )
        items = [
            Candidate(o.id, o.category, o.size, {k: [v] for k, v in a.items()}, o.spare)
            for o, a in zip(objects, drawn, strict=True)
        ]
        missing = first_shortfall(required(goals, same, drawn_goals), items)
        if missing is None:
            return drawn, drawn_goals
    assert missing is not None
    raise DrawRefused(
        f"task file: {missing[1]} in {MAX_DRAWS} draws of the attributes {DrawRefused.MARK}; "
        "list values that can fill every goal"
    )


def draw(
    rng: np.random.Generator,
    listed: Sequence[Mapping[str, AttributeValue | Sequence[AttributeValue]]],
    shuffle: Sequence[str],
    spares: Sequence[bool] | None = None,
) -> list[dict[str, AttributeValue]]:
    """One draw of every object's (or goal's) attributes: one value of each list, then each
    shuffled attribute's values permuted among the items that carry it, spares left out (a
    spare keeps its value, or draws its own from its list)."""
    drawn = [
        {name: _one_of(rng, value) for name, value in attributes.items()} for attributes in listed
    ]
    spare = spares or [False] * len(drawn)
    for name in shuffle:
        carriers = [i for i, attributes in enumerate(drawn) if name in attributes and not spare[i]]
        values = [drawn[i][name] for i in carriers]
        for i, j in zip(carriers, rng.permutation(len(carriers)), strict=True):
            drawn[i][name] = values[int(j)]
    return drawn


def possible_values(
    listed: Sequence[Mapping[str, AttributeValue | Sequence[AttributeValue]]],
    shuffle: Sequence[str],
    spares: Sequence[bool] | None = None,
) -> list[dict[str, list[AttributeValue]]]:
    """Each object's attributes as every value some draw may give it. A shuffled attribute's
    values are its carriers' pooled without repeats, one list shared by every carrier: pooled
    per carrier with repeats, 130 objects of 64 values made each carrier's list 8,320 long."""
    possible: list[dict[str, list[AttributeValue]]] = [
        {name: _values(value) for name, value in attributes.items()} for attributes in listed
    ]
    spare = spares or [False] * len(possible)
    for name in shuffle:  # spares keep their own values
        shuffled = [a for a, s in zip(possible, spare, strict=True) if name in a and not s]
        pooled = list(dict.fromkeys(v for a in shuffled for v in a[name]))
        for attributes in shuffled:
            attributes[name] = pooled
    return possible


def describe(accepts: Mapping[str, AttributeValue | Sequence[float]]) -> str:
    """``colour "red", grade 2, size [0.03, 0.03, 0.03]``: what a goal accepts, in words,
    text quoted (and made printable) so that ``"2"`` and ``2`` read differently."""
    parts = []
    for key, value in accepts.items():
        if isinstance(value, str | int | float):
            parts.append(f"{key} {quoted(value)}")  # "2" (text) is not 2 (a number)
        else:
            parts.append(f"{key} [{', '.join(f'{v:g}' for v in value)}]")
    return ", ".join(parts)


def names(ids: Sequence[str]) -> str:
    shown = ", ".join(ids[:NAMES_SHOWN])
    return shown + (", ..." if len(ids) > NAMES_SHOWN else "")


def _single(value: object) -> bool:
    return isinstance(value, str | int | float)


def _values(value: AttributeValue | Sequence[AttributeValue]) -> list[AttributeValue]:
    """A listed attribute's values; a single value as a list of one."""
    if isinstance(value, str | int | float):
        return [value]
    return list(value)


def _one_of(
    rng: np.random.Generator, value: AttributeValue | Sequence[AttributeValue]
) -> AttributeValue:
    """A listed attribute's value for this draw (a single value is no draw)."""
    if isinstance(value, str | int | float):
        return value
    return value[int(rng.integers(len(value)))]
