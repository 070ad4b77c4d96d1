"""A task's demonstrations come from its registered expert; the others from ``expert``."""

from __future__ import annotations

import pytest

from manigraph_planner.policies import POLICIES, Policy, load_policy
from manigraph_planner.policies.base import TASK_EXPERTS, expert_for
from manigraph_shared.errors import PolicyError


def test_a_task_without_its_own_expert_is_demonstrated_by_expert() -> None:
    assert "stack" not in TASK_EXPERTS
    assert type(expert_for("stack")) is POLICIES["expert"]


def test_every_task_expert_is_also_a_policy_under_its_own_name() -> None:
    for task, expert in TASK_EXPERTS.items():
        policy = expert_for(task)
        assert isinstance(policy, Policy) and type(policy) is expert
        assert POLICIES[policy.name] is expert  # ``--policy <its name>`` serves it


def test_the_retired_size_sort_expert_is_refused_naming_expert_and_the_task_file() -> None:
    with pytest.raises(PolicyError, match=r"--policy expert --task-file examples/tasks/size-sort"):
        load_policy("size-sort-expert")
    assert "size-sort-expert" not in POLICIES and "size-sort" not in TASK_EXPERTS
