"""The five kinds of unwritten rule (examples/tasks/unwritten/, docs/task-files.md): each task
file and its rules file parse together, the teacher told the rules solves episodes without a
violation, and what it is shown and what is recorded are the same with or without them."""

from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_blocks.sim.rules_file import parse_rules_file
from manigraph_blocks.sim.task_file import parse_task_file
from manigraph_lab.demo_recording import DemoProtocol
from manigraph_lab.episode_loop import run_episode
from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_planner.policies import POLICIES
from manigraph_planner.policies.teacher_rules import with_rules
from manigraph_shared.errors import PolicyError

UNWRITTEN = Path(__file__).resolve().parents[2] / "examples" / "tasks" / "unwritten"
KINDS = {
    "colour-place": (8, 12),
    "same-colour": (8, 12),
    "size-tower": (6, 9),
    "red-only-tower": (8, 12),
    "flat-back": (8, 12),
}
#: Variants of a kind: the same task drawn where the physics sim's tripod camera sees it.
CAMERA = ["colour-place-camera"]
FILES = sorted(
    [k for k in KINDS] + [f"{k}-{n}" for k, sizes in KINDS.items() for n in sizes] + CAMERA
)


def texts(name: str) -> tuple[str, str]:
    task = UNWRITTEN / f"{name}.toml"
    return task.read_text(), task.with_name(f"{name}.rules.toml").read_text()


def test_every_kind_ships_with_its_larger_sizes() -> None:
    shipped = {p.name for p in UNWRITTEN.glob("*.toml")}
    assert shipped == {f"{n}.toml" for n in FILES} | {f"{n}.rules.toml" for n in FILES}


@pytest.mark.parametrize("name", FILES)
def test_the_teacher_told_the_rules_solves_it_without_a_violation(name: str) -> None:
    task, rules = texts(name)
    parse_rules_file(rules, task, name)
    assert not any("accepts" in g.model_fields_set for g in parse_task_file(task).goals)
    spec = EvalSpec(
        "file", parse_task_file(task).blocks, episodes=2, seed=9100, task_file=task, rules=rules
    )
    summary = evaluate(with_rules(POLICIES["expert"](), rules), spec)
    assert summary["success_rate"] == 1.0
    assert summary["rule_violations"] == 0 and summary["wrong_object"] == 0


def test_the_camera_variant_is_its_kind_drawn_where_the_camera_sees() -> None:
    task, rules = texts("colour-place-camera")
    kind_task, kind_rules = texts("colour-place")
    assert rules.split("\n", 1)[1] == kind_rules.split("\n", 1)[1]  # the same rules
    starts = {tuple(p) for o in parse_task_file(task).objects for p in o.positions or ()}
    kind_starts = {tuple(p) for o in parse_task_file(kind_task).objects for p in o.positions or ()}
    assert starts < kind_starts and all(abs(y) <= 0.33 for _, y, _ in starts)


def test_the_rule_free_expert_is_judged_by_the_rules() -> None:
    task, rules = texts("colour-place")
    spec = EvalSpec("file", 4, episodes=4, seed=9200, task_file=task, rules=rules)
    summary = evaluate(POLICIES["expert"](), spec)
    assert summary["success_rate"] < 1.0 and summary["rule_violations"] > 0


def test_what_the_teacher_is_shown_is_the_same_with_or_without_rules() -> None:
    task, rules = texts("same-colour")
    (plain,) = DemoProtocol(trajectories=1, seed=9300, task_file=task).requests()
    ruled = plain.replace(rules=rules)
    teacher = with_rules(POLICIES["expert"](), rules)
    with_them, without = run_episode(teacher, ruled), run_episode(POLICIES["expert"](), plain)
    first = with_them.steps[0].scene
    assert first.replace(stamp=0.0) == without.steps[0].scene.replace(stamp=0.0)
    assert all(g.accepts == {} for s in with_them.steps for g in s.scene.goals)


def test_only_the_teacher_is_told_the_rules() -> None:
    _, rules = texts("colour-place")

    class Learned(type(POLICIES["expert"]())):  # type: ignore[misc]
        name = "sage"

    with pytest.raises(PolicyError, match="only the teacher"):
        with_rules(Learned(), rules)
