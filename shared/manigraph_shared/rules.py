"""Rules only the teacher and the judge know (``--rules RULES.toml``, docs/task-files.md).

A rules file has the task file's form: ``[[goals]]`` tables, each a goal ``id`` of the task file
and what it ``accepts`` besides what the task file says, and a file-level ``same = ["colour"]``:
a goal carrying that attribute accepts only objects of its own value. The sim's judge reads the
rules from the reset request (``EpisodeRequest.rules``, checked there as strictly as a task
file); the teacher (``--policy expert`` given the same file) decides on the Scene as the rules
see it (:meth:`TeacherRules.apply`). Neither puts them into a Scene or a TaskLayout: what a
policy sees and what is recorded is the same with or without rules.

:func:`judged_accepts` is the one merge both sides apply.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import msgspec

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Scene

AcceptValue = str | float | list[float]


def judged_accepts(
    accepts: Mapping[str, AcceptValue],
    attributes: Mapping[str, str | float],
    same: Sequence[str],
    added: Mapping[str, AcceptValue],
) -> dict[str, AcceptValue]:
    """What a goal accepts by the rules: its own ``accepts``, then for each attribute in
    ``same`` that it carries (and does not already list) its own value, then what the rules
    add for it (a checked rules file never contradicts a key the task file lists)."""
    merged: dict[str, AcceptValue] = dict(accepts)
    for name in same:
        if name in attributes and name not in merged:
            merged[name] = attributes[name]
    merged.update(added)
    return merged


@dataclass(frozen=True)
class TeacherRules:
    """A rules file as the teacher reads it (the sim checks it against the task file)."""

    same: tuple[str, ...] = ()
    #: Goal id -> what the rules add to what it accepts.
    accepts: Mapping[str, Mapping[str, AcceptValue]] = field(default_factory=dict)

    @classmethod
    def from_text(cls, text: str, source: str = "rules file") -> TeacherRules:
        """The rules of a file's text; ``ConfigError`` (field ``rules``) where it is not a
        rules file's shape at all. What the values mean is checked by the sim."""
        try:
            data = tomllib.loads(text)
        except (tomllib.TOMLDecodeError, RecursionError) as exc:
            raise ConfigError("rules", f"{source}: {exc}") from None
        same = data.get("same", [])
        goals = data.get("goals", [])
        if not isinstance(same, list) or not all(isinstance(n, str) for n in same):
            raise ConfigError("rules", f"{source}: same: give a list of attribute names")
        if not isinstance(goals, list):
            raise ConfigError("rules", f"{source}: goals: give [[goals]] tables")
        accepts: dict[str, dict[str, AcceptValue]] = {}
        for i, goal in enumerate(goals):
            if not isinstance(goal, dict) or not isinstance(goal.get("id"), str):
                raise ConfigError("rules", f"{source}: goals.{i}: give the goal's id")
            wanted = goal.get("accepts", {})
            if not isinstance(wanted, dict):
                raise ConfigError("rules", f"{source}: goals.{i}.accepts: give a table")
            accepts.setdefault(goal["id"], {}).update(wanted)
        return cls(tuple(same), accepts)

    def apply(self, scene: Scene) -> Scene:
        """``scene`` as the rules see it: each goal's ``accepts`` judged by them."""
        goals = [
            msgspec.structs.replace(
                goal,
                accepts=judged_accepts(
                    goal.accepts, goal.attributes, self.same, self.accepts.get(goal.id, {})
                ),
            )
            for goal in scene.goals
        ]
        return msgspec.structs.replace(scene, goals=goals)
