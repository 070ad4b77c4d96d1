"""The goal matching: right on small graphs, and bounded in steps on the worst ones (issue 48)."""

from __future__ import annotations

import itertools
import random

from manigraph_shared.goal_matching import as_masks, match, matching_size, shortfall


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


def brute_force_size(admitted: list[list[int]], banned: int | None) -> int:
    """The most goals that take distinct objects they accept, ``banned`` left out."""
    objects = sorted({i for row in admitted for i in row} - {banned})
    best = 0
    for goals in range(len(admitted) + 1):
        for rows in itertools.combinations(range(len(admitted)), goals):
            for chosen in itertools.permutations(objects, goals):
                if all(i in admitted[g] for g, i in zip(rows, chosen, strict=True)):
                    best = goals
                    break
    return best


def test_the_matching_size_agrees_with_brute_force_with_and_without_a_banned_object() -> None:
    rng = random.Random(1)
    for _ in range(200):
        goals, objects = rng.randint(1, 4), rng.randint(1, 5)
        admitted = [[i for i in range(objects) if rng.random() < 0.5] for _ in range(goals)]
        banned = rng.choice([None, rng.randrange(objects)])
        size = matching_size(as_masks(admitted), banned)
        assert size == brute_force_size(admitted, banned), admitted


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
