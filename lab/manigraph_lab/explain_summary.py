"""``manigraph explain --summary``: what a policy learned, as a table of where it sends what.

It plays N seeded scenes of a task file in one process (as ``manigraph eval`` does) and counts
every placement the policy made: per value of each object attribute that tells objects apart
(``colour red``, ``size 4 x 4 x 4 cm``), the goals it sent those objects to, and how often.
Given the rules file the teacher knew (``--rules R``), each row adds its *agreement*: the
fraction of those placements into a goal that R accepts for that object (R judges; the policy
never sees R). A value no placement took still gets its row (``0`` placements): a distractor
the policy rightly leaves alone. A decision onto a goal that already held an object (the
Scene said ``filled``) fills nothing: it is counted in the row's placements and in a column of
its own, "onto a filled goal", never in a goal's column nor in the agreement.

Goals are grouped so that the table stays readable:

* goals that carry attributes of their own (a bin's colour) are grouped by them
  (``goal colour red``), which is what a rule like ``same = ["colour"]`` is about;
* otherwise by id, and when there are more than :data:`MAX_COLUMNS` ids, by the id's stem
  (``left_0`` ... ``left_5`` -> ``left_*``) where that leaves more than one group.

The JSON (``--json``) also keeps the counts per goal id, whatever the grouping.
"""

from __future__ import annotations

import re
from argparse import Namespace
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TextIO, TypeVar

from manigraph_lab.episode_loop import EpisodeRecord, run_episode
from manigraph_lab.evaluate import EvalSpec, summarize
from manigraph_planner.policies.base import Policy
from manigraph_shared.acceptance import admits
from manigraph_shared.errors import DrawRefused
from manigraph_shared.messages import Scene, SceneGoal, SceneObject
from manigraph_shared.progress import Progress
from manigraph_shared.rules import TeacherRules

__all__ = [
    "MAX_COLUMNS",
    "Placement",
    "PlacementTable",
    "placements",
    "play",
    "run_summary",
    "tabulate",
]

_Entity = TypeVar("_Entity", SceneObject, SceneGoal)

#: More goal ids than this are grouped by their stem (``left_*``) where that helps.
MAX_COLUMNS = 6


@dataclass(frozen=True)
class Placement:
    """One executed decision: the object (by its attributes and size, as words) into a goal."""

    seed: int
    object_id: str
    goal_id: str
    #: Attribute -> value as shown (``colour`` -> ``red``, ``size`` -> ``4 x 4 x 4 cm``).
    values: dict[str, str]
    #: The goal's own attributes as words (``colour red``); empty where it carries none.
    goal_attributes: str
    #: Whether the rules accept the object in that goal; None without rules.
    agrees: bool | None
    #: The goal held an object already: this one was put on top, filling nothing.
    onto_filled: bool = False


@dataclass
class Row:
    """One attribute value: where its objects went."""

    attribute: str
    value: str
    goals: Counter[str] = field(default_factory=Counter)  # by goal id
    groups: Counter[str] = field(default_factory=Counter)  # by the table's grouping
    agreeing: int = 0
    onto_filled: int = 0  # onto a goal that held an object already: in no column

    @property
    def placements(self) -> int:
        return sum(self.goals.values()) + self.onto_filled

    def agreement(self) -> float | None:
        """Of the placements into a free goal, the fraction the rules accept."""
        into = sum(self.goals.values())
        return self.agreeing / into if into else None


@dataclass
class PlacementTable:
    """Rows per attribute value, goal groups as columns."""

    rows: list[Row]
    columns: list[str]
    grouped_by: str  # "goal attributes", "id" or "id stem"
    ruled: bool
    placements: int
    refused_decisions: int

    def as_json(self) -> dict[str, object]:
        return {
            "grouped_by": self.grouped_by,
            "columns": self.columns,
            "placements": self.placements,
            "refused_decisions": self.refused_decisions,
            "rows": [
                {
                    "attribute": row.attribute,
                    "value": row.value,
                    "placements": row.placements,
                    "groups": dict(sorted(row.groups.items())),
                    "goals": dict(sorted(row.goals.items())),
                    "onto_filled": row.onto_filled,
                    **({"agreement": _rounded(row.agreement())} if self.ruled else {}),
                }
                for row in self.rows
            ],
        }

    def markdown(self) -> str:
        prefix = "goal " if self.grouped_by == "goal attributes" else ""
        head = ["objects", "placements", *(prefix + c for c in self.columns)]
        onto = any(row.onto_filled for row in self.rows)
        if onto:
            head.append("onto a filled goal")
        if self.ruled:
            head.append("agrees with rules")
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for row in self.rows:
            cells = [f"{row.attribute} {row.value}", str(row.placements)]
            for column in self.columns:
                count = row.groups.get(column, 0)
                share = f" ({count / row.placements:.0%})" if count and row.placements else ""
                cells.append(f"{count}{share}")
            if onto:
                cells.append(str(row.onto_filled))
            if self.ruled:
                agreement = row.agreement()
                cells.append("-" if agreement is None else f"{agreement:.2f}")
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines)


def play(
    policy: Policy, spec: EvalSpec, progress: TextIO | None = None
) -> tuple[list[EpisodeRecord], list[dict[str, object]], dict[str, object]]:
    """``spec``'s episodes played in-process: the records, the refused seeds (a seed whose draw
    fails is reported while the others run) and ``eval``'s summary of them."""
    import time

    records: list[EpisodeRecord] = []
    refused: list[dict[str, object]] = []
    started = time.perf_counter()
    label = f"explain --summary {policy.name} {spec.task_file_name or spec.task}"
    with Progress(spec.episodes, label, unit="episode", stream=progress) as bar:
        for request in spec.requests():
            try:
                records.append(run_episode(policy, request, noise=spec.noise))
            except DrawRefused as exc:
                refused.append({"seed": request.seed, "reason": str(exc)})
                bar.note(f"  refused {spec.task_file_name}, seed {request.seed}: {exc}")
            bar.update()
    seconds = time.perf_counter() - started
    decisions = sum(len(r.steps) for r in records)
    return records, refused, summarize(policy.name, spec, records, seconds, decisions)


def placements(records: Iterable[EpisodeRecord], rules: TeacherRules | None) -> list[Placement]:
    """Every executed decision of ``records`` (a refused one moved nothing), judged by
    ``rules`` where given."""
    found = []
    for record in records:
        for step in record.steps:
            if not step.ok:
                continue
            obj = _by_id(step.scene.objects, step.action.object_id)
            goal = _by_id(step.scene.goals, step.action.goal_id)
            if obj is None or goal is None:
                continue
            agrees = None
            if rules is not None:
                judged = _by_id(rules.apply(step.scene).goals, goal.id)
                assert judged is not None
                agrees = admits(judged.accepts, obj.id, obj.size.as_tuple(), obj.attributes)
            found.append(
                Placement(
                    record.request.seed,
                    obj.id,
                    goal.id,
                    object_values(obj),
                    _words(goal.attributes),
                    agrees,
                    goal.filled,
                )
            )
    return found


def tabulate(
    found: Sequence[Placement], scenes: Iterable[Scene], refused_decisions: int = 0
) -> PlacementTable:
    """The table of ``found``; ``scenes`` give every object's values (rows even for values no
    placement took) and every goal (the grouping)."""
    values: dict[str, set[str]] = {}
    goals: set[tuple[str, str]] = set()  # (id, own attributes): a shuffle changes the latter
    for scene in scenes:
        for obj in scene.objects:
            for name, value in object_values(obj).items():
                values.setdefault(name, set()).add(value)
        goals.update((goal.id, _words(goal.attributes)) for goal in scene.goals)
    for placement in found:
        for name, value in placement.values.items():
            values.setdefault(name, set()).add(value)
        goals.add((placement.goal_id, placement.goal_attributes))
    telling = [name for name in sorted(values) if len(values[name]) > 1]
    shown = telling or sorted(values)[:1]  # nothing tells objects apart: one row says it all
    group_of, grouped_by = _grouping(goals)
    rows = {
        (name, value): Row(name, value)
        for name in shown
        for value in sorted(values[name], key=_value_order)
    }
    for placement in found:
        for name in shown:
            row = rows[(name, placement.values[name])] if name in placement.values else None
            if row is None:
                continue
            if placement.onto_filled:
                row.onto_filled += 1
                continue
            row.goals[placement.goal_id] += 1
            row.groups[group_of(placement.goal_id, placement.goal_attributes)] += 1
            row.agreeing += bool(placement.agrees)
    columns = sorted({group_of(*goal) for goal in goals}, key=_value_order)
    return PlacementTable(
        list(rows.values()),
        columns,
        grouped_by,
        ruled=any(p.agrees is not None for p in found),
        placements=len(found),
        refused_decisions=refused_decisions,
    )


def object_values(obj: SceneObject) -> dict[str, str]:
    """An object's attributes as words, and its size (``4 x 4 x 4 cm``)."""
    shown = {name: _word(value) for name, value in obj.attributes.items()}
    shown["size"] = " x ".join(f"{v * 100:.3g}" for v in obj.size.as_tuple()) + " cm"
    return shown


def _grouping(goals: set[tuple[str, str]]) -> tuple[_GroupOf, str]:
    if any(words for _, words in goals):
        return _GroupOf(by_attributes=True), "goal attributes"
    ids = {goal for goal, _ in goals}
    stems = {_stem(g) for g in ids}
    if len(ids) > MAX_COLUMNS and 1 < len(stems) < len(ids):
        return _GroupOf(by_stem=True), "id stem"
    return _GroupOf(), "id"


@dataclass(frozen=True)
class _GroupOf:
    """A goal's column: its own attributes (where grouped by them and it has some), else its
    id or the id's stem."""

    by_attributes: bool = False
    by_stem: bool = False

    def __call__(self, goal: str, words: str) -> str:
        if self.by_attributes and words:
            return words
        return _stem(goal) if self.by_stem else goal


def _stem(goal: str) -> str:
    stem = re.sub(r"[_\-]?\d+$", "", goal)
    return f"{stem}_*" if stem and stem != goal else goal


def _value_order(text: str) -> tuple[str, ...]:
    """Natural order: ``level_2`` before ``level_10``, ``4 x 4 x 4 cm`` before ``10 x ...``."""
    return tuple(
        f"{int(part):09d}" if part.isdigit() else part for part in re.split(r"(\d+)", text)
    )


def _by_id(items: Sequence[_Entity], wanted: str) -> _Entity | None:
    return next((item for item in items if item.id == wanted), None)


def _words(attributes: dict[str, str | float]) -> str:
    return ", ".join(f"{name} {_word(value)}" for name, value in sorted(attributes.items()))


def _word(value: object) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 4)


def run_summary(args: Namespace) -> int:
    """``manigraph explain --summary``: play, count, print the table (``--json``: one line)."""
    import json
    import sys

    from manigraph_lab.task_files import checked_files  # the files checked as eval checks them
    from manigraph_planner.policies import load_policy
    from manigraph_planner.policies.teacher_rules import TEACHERS, with_rules
    from manigraph_shared.errors import ConfigError
    from manigraph_tools.episode_plan import EpisodeOptions

    for name in ("checkpoint", "scene_from", "decision", "png"):
        if getattr(args, name) is not None:
            flag = "--" + name.replace("_", "-")
            raise ConfigError(name, f"{flag} explains one decision; --summary plays episodes")
    if args.policy is None or args.task_file is None:
        raise ConfigError("summary", "--summary needs --policy and --task-file")
    if args.episodes < 1:
        raise ConfigError("episodes", "must be >= 1")
    episodes = EpisodeOptions(
        task_file=args.task_file, rules=args.rules, seed=args.seed, episodes=args.episodes
    )
    task_file, blocks, rules = checked_files(episodes)  # a bad file stops here, naming it
    label = episodes.label()
    spec = EvalSpec("file", blocks, 1, args.episodes, args.seed, 0.0, task_file, label, rules=rules)
    policy = load_policy(args.policy, accepts_filter=args.accepts_filter)
    if rules is not None and args.policy in TEACHERS:  # the teacher is told them, as in eval
        policy = with_rules(policy, rules, str(args.rules))
    judge = TeacherRules.from_text(rules, str(args.rules)) if rules is not None else None
    records, refused, summary = play(policy, spec, None if args.json else sys.stderr)
    table = tabulate(
        placements(records, judge),
        (r.steps[0].scene for r in records if r.steps),
        sum(not s.ok for r in records for s in r.steps),
    )
    head = {
        "policy": args.policy,
        "task_file": label,
        **({"rules": str(args.rules)} if rules is not None else {}),
        "episodes": len(records),
        "seed": args.seed,
        "success_rate": round(float(summary["success_rate"]), 4),  # type: ignore[arg-type]
        **({"rule_violations": summary["rule_violations"]} if rules is not None else {}),
        **({"refused_seeds": refused} if refused else {}),
    }
    if args.json:
        print(json.dumps({**head, **table.as_json()}), flush=True)
        return 0
    last = args.seed + args.episodes - 1
    said = [
        f"{label}: {args.policy} over {len(records)} episodes (seeds {args.seed}-{last})",
        f"success {head['success_rate']:.2f}",
        *([f"rule violations {head['rule_violations']}"] if rules is not None else []),
        f"{table.placements} placements",
        *(
            [_counted(table.refused_decisions, "refused decision")]
            if table.refused_decisions
            else []
        ),
        *([_counted(len(refused), "refused seed")] if refused else []),
    ]
    print(", ".join(said))
    print()
    print(table.markdown())
    return 0


def _counted(count: int, noun: str) -> str:
    return f"{count} {noun}" + ("" if count == 1 else "s")
