"""``manigraph explain --summary``: what a policy learned, as a table of where it sends what
(issue #49, item 6). The table's counts are the episodes' own placements."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest
import torch

from manigraph_lab.episode_loop import Step
from manigraph_lab.evaluate import EvalSpec
from manigraph_lab.explain_summary import Placement, placements, play, tabulate
from manigraph_planner.gnn.checkpoint import save_checkpoint
from manigraph_planner.gnn.features import FeatureSpec
from manigraph_planner.gnn.models import ModelConfig, PolicyNet
from manigraph_planner.gnn.task_features import AttributeColumns, TaskFeatures
from manigraph_planner.policies import POLICIES
from manigraph_planner.policies.teacher_rules import with_rules
from manigraph_shared.cli import main
from manigraph_shared.rules import TeacherRules

UNWRITTEN = Path(__file__).resolve().parents[2] / "examples" / "tasks" / "unwritten"


def files(name: str) -> tuple[Path, Path]:
    return UNWRITTEN / f"{name}.toml", UNWRITTEN / f"{name}.rules.toml"


def spec(name: str, blocks: int, episodes: int = 3, seed: int = 9400) -> EvalSpec:
    task, rules = files(name)
    return EvalSpec(
        "file", blocks, 1, episodes, seed, 0.0, task.read_text(), name, rules=rules.read_text()
    )


def test_the_table_counts_what_the_episodes_placed() -> None:
    """The rule-free expert on colour to a place: every executed decision is counted once per
    row of its object's colour, in the column of its goal, and judged by the rules."""
    played = spec("colour-place", 4)
    rules = TeacherRules.from_text(played.rules or "")
    records, refused, summary = play(POLICIES["expert"](), played)
    assert not refused and len(records) == 3
    found = placements(records, rules)
    executed = [(s.action.object_id, s.action.goal_id) for r in records for s in r.steps if s.ok]
    assert [(p.object_id, p.goal_id) for p in found] == executed
    table = tabulate(found, (r.steps[0].scene for r in records))
    assert table.grouped_by == "id" and table.columns == ["left_0", "left_1", "right_0", "right_1"]
    assert [(row.attribute, row.value) for row in table.rows] == [
        ("colour", "blue"),
        ("colour", "red"),
    ]  # size is the same for every block: no row of its own
    # Colours are shuffled per seed: each placement's colour is its own episode's.
    colours = [
        o.attributes["colour"]
        for r in records
        for s in r.steps
        if s.ok
        for o in s.scene.objects
        if o.id == s.action.object_id
    ]
    for row in table.rows:
        mine = [g for (_, g), c in zip(executed, colours, strict=True) if c == row.value]
        assert row.goals == Counter(mine) and row.placements == len(mine)
        left = sum(g.startswith("left") for g in mine)
        agreeing = left if row.value == "red" else len(mine) - left
        assert row.agreement() == pytest.approx(agreeing / len(mine))
    # The rule-free expert breaks the rule: the judge saw it too.
    assert any(not p.agrees for p in found) and int(summary["rule_violations"]) > 0  # type: ignore[call-overload]
    assert table.markdown().splitlines()[0] == (
        "| objects | placements | left_0 | left_1 | right_0 | right_1 | agrees with rules |"
    )


def test_the_teacher_told_the_rules_agrees_with_them_everywhere() -> None:
    played = spec("colour-place-12", 12, episodes=2)
    teacher = with_rules(POLICIES["expert"](), played.rules)
    records, _, _ = play(teacher, played)
    table = tabulate(
        placements(records, TeacherRules.from_text(played.rules or "")),
        (r.steps[0].scene for r in records),
    )
    # 12 goals: grouped by the ids' stems; red all to the left, blue all to the right.
    assert table.grouped_by == "id stem" and table.columns == ["left_*", "right_*"]
    rows = {row.value: row for row in table.rows}
    assert rows["red"].groups == Counter({"left_*": 12}) and rows["red"].agreement() == 1.0
    assert rows["blue"].groups == Counter({"right_*": 12}) and rows["blue"].agreement() == 1.0
    assert "| colour red | 12 | 12 (100%) | 0 | 1.00 |" in table.markdown()


def test_goals_with_attributes_of_their_own_are_grouped_by_them() -> None:
    played = spec("same-colour", 4, episodes=2)
    teacher = with_rules(POLICIES["expert"](), played.rules)
    records, _, _ = play(teacher, played)
    found = placements(records, TeacherRules.from_text(played.rules or ""))
    table = tabulate(found, (r.steps[0].scene for r in records))
    assert table.grouped_by == "goal attributes"
    assert table.columns == ["colour blue", "colour red"]
    rows = {row.value: row for row in table.rows}
    assert rows["red"].groups == Counter({"colour red": 4})
    assert rows["blue"].groups == Counter({"colour blue": 4})
    assert sum(rows["red"].goals.values()) == 4  # by id too, in the JSON


def test_a_value_no_placement_took_still_has_its_row() -> None:
    """Only red in the tower: the blue distractors are never placed, and the table says so."""
    played = spec("red-only-tower", 4, episodes=2)
    records, _, _ = play(with_rules(POLICIES["expert"](), played.rules), played)
    table = tabulate(placements(records, None), (r.steps[0].scene for r in records))
    rows = {row.value: row for row in table.rows}
    assert rows["blue"].placements == 0 and rows["red"].placements == 4
    assert not table.ruled and "agrees" not in table.markdown()
    assert "| colour blue | 0 | 0 | 0 |" in table.markdown()


def test_sizes_are_rows_when_they_tell_objects_apart() -> None:
    played = spec("size-tower", 3, episodes=1)
    records, _, _ = play(with_rules(POLICIES["expert"](), played.rules), played)
    table = tabulate(
        placements(records, TeacherRules.from_text(played.rules or "")),
        (r.steps[0].scene for r in records),
    )
    assert [row.value for row in table.rows] == ["6 x 6 x 4 cm", "6.5 x 6.5 x 4 cm", "7 x 7 x 4 cm"]
    assert [row.goals for row in table.rows] == [
        Counter({"level_2": 1}),
        Counter({"level_1": 1}),
        Counter({"level_0": 1}),
    ]


def test_a_placement_onto_a_filled_goal_fills_no_column() -> None:
    def placed(goal: str, agrees: bool, onto: bool = False) -> Placement:
        return Placement(0, "block_0", goal, {"colour": "blue"}, "", agrees, onto)

    found = [placed("right_0", True), placed("left_0", False), placed("left_0", False, True)]
    table = tabulate(found, [])
    (row,) = table.rows
    assert row.placements == 3 and row.onto_filled == 1
    assert row.goals == Counter({"right_0": 1, "left_0": 1}) and row.agreement() == 0.5
    assert table.markdown().splitlines()[2] == "| colour blue | 3 | 1 (33%) | 1 (33%) | 1 | 0.50 |"


def colour_checkpoint(tmp_path: Path) -> Path:
    spec = FeatureSpec.for_task(TaskFeatures((AttributeColumns("colour", ("blue", "red")),)))
    torch.manual_seed(0)
    net = PolicyNet(ModelConfig("sage", features=spec))
    return save_checkpoint(tmp_path / "colour.pt", net, training_config={}, data_hash="h")


def test_the_command_prints_the_table_and_its_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A tiny untrained policy: the JSON's counts are those of the same episodes played here."""
    task, rules = files("colour-place")
    policy = str(colour_checkpoint(tmp_path))
    argv = ["explain", "--summary", "--policy", policy, "--task-file", str(task)]
    argv += ["--rules", str(rules), "--episodes", "2", "--seed", "9500"]
    assert main([*argv, "--json"]) == 0
    data = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert data["episodes"] == 2 and data["task_file"] == "colour-place"
    assert {"success_rate", "rule_violations", "rows", "columns"} <= set(data)

    from manigraph_planner.policies import load_policy

    played = spec("colour-place", 4, episodes=2, seed=9500)
    records, _, _ = play(load_policy(policy), played)
    executed = [s for r in records for s in r.steps if s.ok]
    assert data["placements"] == len(executed)
    by_goal: Counter[str] = Counter()
    for row in data["rows"]:  # colour is the only row attribute: each placement once
        by_goal.update(row["goals"])
    onto = [s for s in executed if _held(s)]
    assert by_goal == Counter(s.action.goal_id for s in executed if not _held(s))
    assert sum(row["onto_filled"] for row in data["rows"]) == len(onto)
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert text.startswith("colour-place: ") and "| objects | placements |" in text


def _held(step: Step) -> bool:
    """The decision's goal held an object already (the Scene said so)."""
    return any(g.filled for g in step.scene.goals if g.id == step.action.goal_id)


def test_summary_flags_are_checked(capsys: pytest.CaptureFixture[str]) -> None:
    task = str(files("colour-place")[0])
    wrong = {
        "--summary needs --policy and --task-file": ["--summary", "--task-file", task],
        "--policy goes with --summary": ["--policy", "expert"],
        "--checkpoint explains one decision": [
            "--summary", "--policy", "expert", "--task-file", task, "--checkpoint", "x.pt"
        ],
        "episodes: must be >= 1": [
            "--summary", "--policy", "expert", "--task-file", task, "--episodes", "0"
        ],
    }  # fmt: skip
    for message, argv in wrong.items():
        assert main(["explain", *argv]) == 78
        assert message in capsys.readouterr().err
