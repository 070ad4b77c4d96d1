"""``manigraph improve``: one round of DAgger on a tiny task, with the real demos, training, world
and teacher. The labels are one per scene the policy was asked about, each the teacher's
decision (told the rules) on the scene as the policy saw it; the improved checkpoint loads and
decides; bad input is one named line and a non-zero exit."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
from pathlib import Path

import pytest

from manigraph_lab.demo_recording import family_expert
from manigraph_lab.episode_loop import run_episode
from manigraph_lab.teacher_dagger import ImprovePlan, VisitedScenes
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.teacher_rules import with_rules
from manigraph_shared.cli import main
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene

#: Two red and two blue blocks (colours shuffled per seed), two bins a side: no rule in the file.
BLOCK = """
[[objects]]
id = "block_{i}"
category = "block"
position = [0.{x}, -0.30, 0.02]
attributes = {{ colour = "{colour}" }}
"""
TINY = (
    'name = "tiny colour place"\nshuffle = ["colour"]\n'
    + "".join(
        BLOCK.format(i=i, x=35 + 5 * i, colour=colour)
        for i, colour in enumerate(["red"] * 2 + ["blue"] * 2)
    )
    + "{goals}"
)
GOAL = """
[[goals]]
id = "{id}"
category = "block"
position = [0.62, {y}, 0.02]
"""
PLACES = GOAL.format(id="left_0", y=0.08) + GOAL.format(id="left_1", y=0.15)
PLACES += GOAL.format(id="right_0", y=-0.08) + GOAL.format(id="right_1", y=-0.15)
RULES = "".join(
    f'[[goals]]\nid = "{side}_{i}"\naccepts = {{ colour = "{colour}" }}\n'
    for side, colour in (("left", "red"), ("right", "blue"))
    for i in (0, 1)
)
SEED, EPISODES = 3000, 3


def _policy(folder: Path, goals: str, name: str) -> tuple[Path, Path, Path]:
    """A task file, its rules and a policy trained for 1 epoch on 2 of its demonstrations."""
    folder.mkdir()
    task, rules = folder / f"{name}.toml", folder / f"{name}.rules.toml"
    task.write_text(TINY.replace("{goals}", goals))
    rules.write_text(RULES if "left_0" in goals else "")
    demos, policy = folder / "demos.mcap", folder / "p.pt"
    demo = ["demos", "--task-file", str(task), "--trajectories", "2", "-o", str(demos)]
    assert main([*demo, "--rules", str(rules)] if "left_0" in goals else demo) == 0
    assert main(["train", str(demos), "--epochs", "1", "--copies", "1", "--threads", "1",
                 "-o", str(policy)]) == 0  # fmt: skip
    return task, rules, policy


@pytest.fixture(scope="module")
def improved(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    root = tmp_path_factory.mktemp("improve")
    task, rules, policy = _policy(root / "tiny", PLACES, "tiny")
    output = root / "tiny" / "p2.pt"
    argv = ["improve", "--policy", str(policy), "--task-file", str(task), "--rules", str(rules)]
    argv += ["--rounds", "1", "--episodes", str(EPISODES), "--seed", str(SEED)]
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main([*argv, "--threads", "1", "-o", str(output)])
    summary = json.loads(printed.getvalue().splitlines()[-1]) if code == 0 else None
    return {"code": code, "summary": summary, "root": root, "task": task, "rules": rules,
            "policy": policy}  # fmt: skip


def _summary(improved: dict[str, object]) -> dict:
    assert improved["code"] == 0
    return improved["summary"]  # type: ignore[return-value]


def _labels(path: Path) -> list[tuple[Scene, Action]]:
    scenes: dict[tuple[str, int], Scene] = {}
    labels = []
    for item in read_log(path, [Scene.key, Action.key]):
        message = item.decode()
        if isinstance(message, Scene):
            scenes[(message.episode_id, message.sequence)] = message
        elif isinstance(message, Action):
            labels.append((scenes[(message.episode_id, message.scene_sequence)], message))
    return labels


def test_one_round_labels_every_scene_the_policy_visited_and_nothing_else(
    improved: dict[str, object],
) -> None:
    (report,) = _summary(improved)["rounds"]
    labels = _labels(Path(report["labels_file"]))
    assert report["episodes"] == EPISODES and report["labels"] == len(labels) > 0
    # Played again, the policy is asked about the same scenes (those it acted on, then the one
    # an episode may end on, undecided): each is labelled once, in order, but those the teacher
    # has nothing to do in (a wrong block in every goal another could move to).
    task = Path(str(improved["task"])).read_text()
    rules = Path(str(improved["rules"])).read_text()
    plan = ImprovePlan(Path("p.pt"), task, "tiny", rules, "rules", Path("p2.pt"), 1, EPISODES, SEED)
    policy = load_policy(str(improved["policy"]))
    visited = 0
    for request in plan.requests(1):
        visits = VisitedScenes(policy)
        acted = [step.scene for step in run_episode(visits, request).steps]
        assert visits.scenes[: len(acted)] == acted and len(visits.scenes) - len(acted) in (0, 1)
        teacher = with_rules(family_expert(request), rules)
        decided = [s.sequence for s in visits.scenes if teacher.decide(s) is not None]
        labelled = [s.sequence for s, _ in labels if s.episode_id == request.episode_id]
        assert labelled == decided
        visited += len(visits.scenes)
    assert report["scenes_visited"] == visited


def test_each_label_is_the_teachers_decision_on_the_scene_as_the_policy_saw_it(
    improved: dict[str, object],
) -> None:
    (report,) = _summary(improved)["rounds"]
    rules = Path(str(improved["rules"])).read_text()
    plan = ImprovePlan(Path("p.pt"), "", "tiny", rules, "r", Path("p2.pt"), 1, EPISODES, SEED)
    (request, *_) = plan.requests(1)
    teacher = with_rules(family_expert(request), rules)
    for scene, action in _labels(Path(report["labels_file"])):
        decision = teacher.decide(scene)
        assert decision is not None and (action.object_id, action.goal_id) == decision.pair
        assert action.policy == teacher.name and action.scene_sequence == scene.sequence
        assert all(goal.accepts == {} for goal in scene.goals)  # the rules stay the teacher's


def test_the_improved_policy_loads_decides_and_names_its_data(improved: dict[str, object]) -> None:
    summary = _summary(improved)
    (report,) = summary["rounds"]
    improved_policy = load_policy(summary["checkpoint"]["path"])
    scene, _ = _labels(Path(report["labels_file"]))[0]
    assert improved_policy.decide(scene) is not None
    info = improved_policy.info
    assert info.training_config["demos"][-1] == report["labels_file"]
    assert info.training_config["epochs"] == 1 and info.metrics["improve_round"] == 1
    assert info.metrics["demonstration_samples"] == 8 + report["labels"]  # 2 demos of 4 steps


def _refused(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    capsys.readouterr()
    code = main(argv)
    err = capsys.readouterr().err
    assert code != 0 and "Traceback" not in err and err.startswith("manigraph improve:")
    return err


def _argv(policy: Path, task: Path, rules: Path, output: Path) -> list[str]:
    return ["improve", "--policy", str(policy), "--task-file", str(task), "--rules", str(rules),
            "--rounds", "1", "--episodes", "1", "-o", str(output)]  # fmt: skip


def test_a_checkpoint_of_another_task_is_refused_naming_it(
    improved: dict[str, object], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    _, _, other = _policy(tmp_path / "other", GOAL.format(id="shelf", y=0.1), "other")
    task, rules = Path(str(improved["task"])), Path(str(improved["rules"]))
    err = _refused(capsys, _argv(other, task, rules, tmp_path / "p2.pt"))
    assert "another task" in err and "shelf" in err
    assert not (tmp_path / "p2.round1.mcap").exists()


def test_rules_that_do_not_fit_the_task_file_are_refused_naming_them(
    improved: dict[str, object], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    rules = tmp_path / "wrong.rules.toml"
    rules.write_text('[[goals]]\nid = "bin_9"\naccepts = { colour = "red" }\n')
    argv = _argv(
        Path(str(improved["policy"])), Path(str(improved["task"])), rules, tmp_path / "o.pt"
    )
    assert "bin_9" in _refused(capsys, argv)


def test_unreadable_demonstrations_named_in_the_checkpoint_are_refused(
    improved: dict[str, object], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    folder = tmp_path / "moved"
    shutil.copytree(Path(str(improved["root"])) / "tiny", folder)
    demos = folder / "demos.mcap"
    argv = ["train", str(demos), "--epochs", "1", "--copies", "1", "--threads", "1"]
    assert main([*argv, "-o", str(folder / "p.pt")]) == 0
    capsys.readouterr()
    demos.write_bytes(b"not an mcap file")
    argv = _argv(folder / "p.pt", folder / "tiny.toml", folder / "tiny.rules.toml", folder / "o.pt")
    assert str(demos) in _refused(capsys, argv)
    demos.unlink()
    assert "no such file" in _refused(capsys, argv)
