"""The example tasks written only as task files (examples/tasks/, docs/task-files.md): each
small file and its evaluation file with twice the objects lay out varied scenes per seed, and
the geometric world scores them by what each goal accepts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from manigraph_blocks.sim.task_file import FileTask, parse_task_file
from manigraph_shared.goal_matching import maximum_matching
from manigraph_shared.messages import EpisodeRequest, GripperOp, RobotCommand
from manigraph_sim.geometric.backend import GeometricBackend
from manigraph_sim.world_model import Layout

TASKS = Path(__file__).resolve().parents[2] / "examples" / "tasks"
#: Each example task: its training file and its evaluation file (twice the objects).
EXAMPLES = {
    "size-sort": "size-sort-8",
    "colour-sort": "colour-sort-8",
    "kitting": "kitting-6",
    "red-tower": "red-tower-8",
}
#: More evaluation sizes: size sort at three times its training file's blocks.
LARGER = ("size-sort-12",)
FILES = sorted([*EXAMPLES, *EXAMPLES.values(), *LARGER])


def text(name: str) -> str:
    return (TASKS / f"{name}.toml").read_text()


def layout(name: str, seed: int) -> Layout:
    return FileTask(parse_task_file(text(name))).layout(np.random.default_rng(seed))


def assignment(scene: Layout) -> list[tuple[str, str]]:
    """(object, goal) for every required goal, each goal given an object it accepts, lowest
    goals first (a tower from its base)."""
    goals = sorted(
        (g for g in scene.goals if g.id in scene.required_goals()), key=lambda g: g.position[2]
    )
    admitted = [[i for i, b in enumerate(scene.bodies) if g.admits(b)] for g in goals]
    taken = maximum_matching(admitted)
    assert None not in taken
    return [(scene.bodies[i].id, g.id) for i, g in zip(taken, goals, strict=True) if i is not None]


def play(name: str, seed: int, pairs: list[tuple[str, str]]) -> GeometricBackend:
    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="e", task="file", task_file=text(name), seed=seed), 0.0)
    for object_id, goal_id in pairs:
        scene = sim.scene(0.0)
        assert scene is not None
        where, to = scene.object(object_id).position, scene.goal(goal_id).position
        for op, position in ((GripperOp.PICK, where), (GripperOp.PLACE, to)):
            command = RobotCommand(
                command_id="c",
                decision_id="d",
                op=op,
                object_id=object_id,
                position=position,
                stamp=0.0,
            )
            assert sim.execute(command, 0.0).ok
    return sim


@pytest.mark.parametrize("small", sorted(EXAMPLES))
def test_the_evaluation_file_has_twice_the_objects_and_goals(small: str) -> None:
    a, b = parse_task_file(text(small)), parse_task_file(text(EXAMPLES[small]))
    assert len(b.objects) == 2 * len(a.objects) and len(b.goals) == 2 * len(a.goals)
    # The evaluation file names no attribute value the training file does not.
    values = {(n, str(v)) for o in a.objects for n, v in o.attributes.items()}
    assert {(n, str(v)) for o in b.objects for n, v in o.attributes.items()} <= values
    assert a.shuffle == b.shuffle


def test_size_sort_12_has_six_blocks_of_each_size_and_a_goal_for_each() -> None:
    spec = parse_task_file(text("size-sort-12"))
    sizes = sorted(o.size[0] for o in spec.objects)
    assert sizes == [0.03] * 6 + [0.07] * 6
    accepted = sorted(g.accepts["size"][0] for g in spec.goals)  # type: ignore[index]
    assert accepted == sizes


@pytest.mark.parametrize("name", FILES)
def test_twenty_seeds_give_twenty_scenes_that_fit(name: str) -> None:
    scenes = [layout(name, seed) for seed in range(20)]
    where = {str([b.position.round(4).tolist() for b in s.bodies]) for s in scenes}
    assert len(where) == 20
    for scene in scenes:
        scene.validate()
        for i, a in enumerate(scene.bodies):  # no two objects overlap
            for b in scene.bodies[i + 1 :]:
                gap = np.abs(a.position - b.position) - (a.size + b.size) / 2
                assert gap.max() > -1e-3, (name, a.id, b.id)


@pytest.mark.parametrize("name", FILES)
def test_each_goal_filled_with_what_it_accepts_succeeds(name: str) -> None:
    for seed in (0, 1):
        sim = play(name, seed, assignment(layout(name, seed)))
        end = sim.end_event(0.0)
        assert end is not None and end.success, (name, seed, end)
        assert end.goals_wrong_object == 0


@pytest.mark.parametrize("name", FILES)
def test_an_object_a_goal_does_not_accept_leaves_it_empty(name: str) -> None:
    scene = layout(name, 3)
    low = min(g.position[2] for g in scene.goals)
    goal, body = next(
        (g, b)
        for g in scene.goals
        for b in scene.bodies
        if g.position[2] == low and g.category == b.category and not g.admits(b)
    )
    sim = play(name, 3, [(body.id, goal.id)])
    after = sim.scene(0.0)
    assert after is not None and not after.goal(goal.id).filled
    assert not after.object(body.id).filled
    assert sim.evaluation().wrong_object_goals == {goal.id}  # a 7 cm block in a 3 cm goal too
