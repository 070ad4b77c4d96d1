"""The size-sort task (docs/tasks/size-sort.md) through the whole stack: ``manigraph up`` with
the task's expert as its planner policy, router, sim, planner and skills as real processes."""

from __future__ import annotations

import json

import pytest

from manigraph_tools.testing import run_up

pytestmark = pytest.mark.integration


def test_up_sorts_two_episodes_with_the_tasks_expert() -> None:
    result = run_up(
        "--task", "size-sort", "--blocks", "6", "--policy", "size-sort-expert",
        "--episodes", "2", "--seed", "7", "--json",
    )  # fmt: skip
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["task"] == "size-sort" and summary["episodes"] == 2
    assert summary["success_rate"] == 1.0, summary
