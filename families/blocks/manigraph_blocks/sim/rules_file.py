"""Rules only the teacher and the judge know: a rules file, in the task file's format.

```toml
name = "red left, blue right"       # optional
same = ["colour"]                   # a goal carrying colour accepts only its own colour

[[goals]]
id = "bin_left_0"                   # a goal of the task file
accepts = { colour = "red" }        # added to what the task file's goal accepts
```

The rules travel in the reset request (``EpisodeRequest.rules``) beside the task file, and only
the judge reads them: a goal accepts what the task file says *and* what the rules add (a key
both list must agree), and under the rules' ``same`` its own value of those attributes. The
episode succeeds, and a goal holds a wrong object, by these rules; every placement into a goal
they refuse is a rule violation (``world_model.Judge``). The Scene and the TaskLayout are laid
out from the task file alone, so what a policy sees is the same with or without rules.

A rules file is checked as strictly as a task file, against the task file it judges: its goals
must be the task file's (an unknown id is named, with the one probably meant), what it accepts
must be carried by some object, and the objects that are not spares must still be able to fill
every required goal; each problem names its line. A seed whose draw the rules cannot fill is
refused naming the goal.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from difflib import get_close_matches
from functools import lru_cache

from pydantic import Field, ValidationError, field_validator

from manigraph_blocks.sim import task_attributes
from manigraph_blocks.sim.task_file import NESTED_TOO_DEEPLY, TaskFile, parse_task_file
from manigraph_blocks.sim.task_file_errors import describe_errors, line_of
from manigraph_blocks.sim.task_file_specs import (
    MAX_PROBLEMS_NAMED,
    RESERVED,
    AcceptedValue,
    AttributeName,
    Name,
    _Strict,
    known_accept_forms,
)
from manigraph_shared.errors import DrawRefused, TaskError
from manigraph_shared.printable import printable, quoted
from manigraph_shared.rules import judged_accepts
from manigraph_sim.world_model import Goal, Judge, Layout


class RuleGoalSpec(_Strict):
    id: Name
    #: Added to what the task file's goal accepts: every key must match.
    accepts: dict[AttributeName, AcceptedValue] = Field(default_factory=dict, max_length=16)

    @field_validator("accepts")
    @classmethod
    def _known_forms(cls, accepts: dict[str, object]) -> dict[str, object]:
        return known_accept_forms(accepts)


class RulesFile(_Strict):
    name: str = Field("rules", max_length=128)
    #: Attributes a goal carrying them matches: it accepts only objects of its own value.
    same: list[AttributeName] = Field(default_factory=list, max_length=16)
    goals: list[RuleGoalSpec] = Field(default_factory=list, max_length=256)


@dataclass(frozen=True)
class Rules:
    """A checked rules file, for the task file it was checked against."""

    spec: RulesFile
    task: TaskFile

    def accepts(self, goal: Goal) -> dict[str, str | float | list[float]]:
        """What ``goal`` (as laid out: the task file's accepts, its drawn attributes) accepts
        by the rules (``manigraph_shared.rules.judged_accepts``)."""
        added = {
            k: v if isinstance(v, str | int | float) else list(v)
            for rule in self.spec.goals
            if rule.id == goal.id
            for k, v in rule.accepts.items()
        }
        return judged_accepts(goal.accepts, goal.attributes, self.spec.same, added)

    def judge(self, layout: Layout) -> Judge:
        """The judge of ``layout``'s episode; ``TaskError`` naming the goal when this seed's
        draw leaves a required goal that the rules let no object fill."""
        goals = {
            g.id: Goal(g.id, g.category, g.position, self.accepts(g), dict(g.attributes))
            for g in layout.goals
        }
        spares = {o.id for o in self.task.objects if o.spare}
        index = {g.id: i for i, g in enumerate(self.task.goals)}
        wanted = [
            task_attributes.Wanted(index[g.id], g.id, g.category, g.accepts)
            for g in goals.values()
            if g.id not in layout.optional_goals
        ]
        items = [
            task_attributes.Candidate(
                b.id,
                b.category,
                (float(b.size[0]), float(b.size[1]), float(b.size[2])),
                {k: [v] for k, v in b.attributes.items()},
                b.id in spares,
            )
            for b in layout.bodies
        ]
        missing = task_attributes.first_shortfall(wanted, items)
        if missing is not None:
            raise DrawRefused(f"rules: {missing[1]}, by the rules, {DrawRefused.MARK}")
        return Judge(goals)


def parse_rules_file(text: str, task_text: str, source: str | None = None) -> Rules:
    """Check a rules file's text against the task file it judges; ``TaskError`` names the
    line and the field, in words (a bad task file is the task file's refusal)."""
    task = parse_task_file(task_text)
    parsed = _parsed(text, task_text, source)
    if isinstance(parsed, str):
        raise TaskError(parsed)
    return Rules(parsed, task)


@lru_cache(maxsize=8)
def _parsed(text: str, task_text: str, source: str | None) -> RulesFile | str:
    prefix = f"rules file {source}" if source else "rules file"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        return printable(f"{prefix}: {exc}")
    except RecursionError:
        return printable(f"{prefix}: {NESTED_TOO_DEEPLY}")
    try:
        spec = RulesFile.model_validate(data)
    except ValidationError as exc:
        problems = describe_errors(
            exc.errors(include_url=False), text, RulesFile, {"goals": RuleGoalSpec}
        )
        return printable(f"{prefix}: " + "; ".join(problems))
    except RecursionError:
        return printable(f"{prefix}: {NESTED_TOO_DEEPLY}")
    problems = _against(spec, parse_task_file(task_text), text.splitlines())
    if problems:
        shown = problems[:MAX_PROBLEMS_NAMED]
        more = len(problems) - len(shown)
        return printable(f"{prefix}: " + "; ".join(shown) + (f"; and {more} more" if more else ""))
    return spec


def _against(spec: RulesFile, task: TaskFile, lines: list[str]) -> list[str]:
    """What the rules ask that the task file cannot give, each with its line."""
    problems: list[str] = []

    def at(loc: tuple[str | int, ...], message: str) -> None:
        line = line_of(lines, loc)
        field = ".".join(str(part) for part in loc)
        problems.append((f"line {line}: " if line else "") + f"{field}: {message}")

    goals = {g.id: g for g in task.goals}
    carried = sorted({name for o in task.objects for name in o.attributes})
    ids = {o.id for o in task.objects}
    seen: set[str] = set()
    for i, rule in enumerate(spec.goals):
        goal = goals.get(rule.id)
        if goal is None:
            close = get_close_matches(rule.id, list(goals), n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]}?" if close else ""
            at(("goals", i, "id"), f"the task file has no goal {rule.id}{hint}")
            continue
        if rule.id in seen:
            at(("goals", i, "id"), f"{rule.id} has rules twice; give them in one table")
        seen.add(rule.id)
        for key, value in rule.accepts.items():
            loc = ("goals", i, "accepts", key)
            if key == "id" and value not in ids:
                at(loc, f"{rule.id} would accept {value}, and no object is called that")
            elif key not in RESERVED and key not in carried:
                close = get_close_matches(key, carried, n=1, cutoff=0.6)
                hint = f"; did you mean {close[0]}?" if close else ""
                at(loc, f"no object carries an attribute {key}{hint}")
            elif key in goal.accepts and goal.accepts[key] != value:
                at(
                    loc,
                    f"the task file's {rule.id} already accepts {key} "
                    f"{_shown(goal.accepts[key])}; a rule cannot ask for {_shown(value)} too",
                )
    for i, name in enumerate(spec.same):
        if not any(name in g.attributes for g in task.goals):
            at(("same", i), f"no goal of the task file carries an attribute {name}")
        elif not any(name in o.attributes for o in task.objects):
            at(("same", i), f"no object of the task file carries an attribute {name}")
    if problems:
        return problems
    wanted = _judged_goals(spec, task)
    missing = task_attributes.first_shortfall(wanted, task.candidates)
    if missing is not None:
        return [f"{missing[1]}, by the rules"]
    return []


def _judged_goals(spec: RulesFile, task: TaskFile) -> list[task_attributes.Wanted]:
    """The task file's required goals with the rules' accepts added (and ``same``'s values
    where a goal's value is certain before any draw)."""
    added = {rule.id: rule.accepts for rule in spec.goals}
    same = [*task.same, *spec.same]
    return [
        task_attributes.Wanted(w.index, w.id, w.category, {**w.accepts, **added.get(w.id, {})})
        for w in task_attributes.required(task.goals, same, shuffle=task.shuffle)
    ]


def _shown(value: object) -> str:
    if isinstance(value, str | int | float):
        return quoted(value)
    return "[" + ", ".join(f"{float(v):g}" for v in value) + "]"  # type: ignore[attr-defined]


__all__ = ["Rules", "RulesFile", "parse_rules_file"]
