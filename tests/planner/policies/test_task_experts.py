"""A task's demonstrations come from its registered expert; the others from ``expert``."""

from __future__ import annotations

from manigraph_planner.policies import POLICIES, Policy
from manigraph_planner.policies.base import TASK_EXPERTS, expert_for


def test_a_task_without_its_own_expert_is_demonstrated_by_expert() -> None:
    assert "stack" not in TASK_EXPERTS
    assert type(expert_for("stack")) is POLICIES["expert"]


def test_every_task_expert_is_also_a_policy_under_its_own_name() -> None:
    for task, expert in TASK_EXPERTS.items():
        policy = expert_for(task)
        assert isinstance(policy, Policy) and type(policy) is expert
        assert POLICIES[policy.name] is expert  # ``--policy <its name>`` serves it
