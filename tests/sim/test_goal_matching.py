"""The goal matching: right on small graphs, and bounded in steps on the worst ones (issue 48)."""

from __future__ import annotations

import itertools
import random

from manigraph_sim.families.blocks.goal_matching import as_masks, match, shortfall


def brute_force_fills_every_goal(admitted: list[list[int]]) -> bool:
    objects = sorted({i for row in admitted for i in row})
    for chosen in itertools.permutations(objects, len(admitted)):
        if all(item in row for item, row in zip(chosen, admitted, strict=True)):
            return True
    return not admitted


def test_agrees_with_brute_force_and_names_a_hall_violation() -> None:
    rng = random.Random(0)
    for _ in range(300):
        goals, objects = rng.randint(1, 5), rng.randint(1, 6)
        admitted = [[i for i in range(objects) if rng.random() < 0.4] for _ in range(goals)]
        missing = shortfall(admitted)
        assert (missing is None) == brute_force_fills_every_goal(admitted), admitted
        if missing is not None:  # those goals outnumber the objects any of them accepts
            assert missing.goal in missing.goals
            assert len(missing.objects) < len(missing.goals)
            reachable = {i for g in missing.goals for i in admitted[g]}
            assert reachable == set(missing.objects)


def test_a_complete_matching_gives_each_goal_an_object_it_accepts() -> None:
    admitted = [[0, 1], [0], [1, 2]]
    taken = match(as_masks(admitted)).taken
    assert sorted(t for t in taken if t is not None) == [0, 1, 2]
    assert all(t in row for t, row in zip(taken, admitted, strict=True))


def test_steps_stay_within_goals_times_twice_the_objects_on_the_worst_graphs() -> None:
    n = 256
    graphs = {
        "every goal accepts every object": [(1 << n) - 1] * n,
        "one object too few": [(1 << (n - 1)) - 1] * n,
        "a staircase": [(1 << (g + 1)) - 1 for g in range(n)],
        "a reversed staircase": [(1 << n) - (1 << g) for g in range(n)],
    }
    for name, rows in graphs.items():
        result = match(rows)
        assert result.steps <= n * (2 * n + 1) + n, (name, result.steps)
        stopped = match(rows, complete=False)
        assert stopped.steps <= result.steps, name
