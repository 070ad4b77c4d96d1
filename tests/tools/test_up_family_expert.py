"""``manigraph up`` without ``--policy`` plays the expert of the task's family: its tools part
says which (``ToolsFamily.expert_of``), and that name is a policy the planner registers."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from manigraph_planner.policies import POLICIES
from manigraph_tools.family import FAMILIES
from manigraph_tools.stack_processes import planner_argv, planner_policy


def up_args(task: str, policy: str = "expert", **options: object) -> argparse.Namespace:
    fields = {"preference": None, "objects": None, "task_file": None, "rules": None}
    return argparse.Namespace(
        task=task,
        policy=policy,
        explain_decisions=False,
        accepts_filter="on",
        **{**fields, **options},
    )


@pytest.mark.parametrize(
    ("task", "options", "expert"),
    [
        ("stack", {}, "expert"),
        ("shelf", {"objects": 6}, "shelf-expert"),
        ("dishwasher", {}, "dishwasher-top-bottom"),
        ("dishwasher", {"preference": "left-right"}, "dishwasher-left-right"),
    ],
)
def test_the_default_policy_is_the_task_familys_expert(
    task: str, options: dict[str, object], expert: str
) -> None:
    assert planner_policy(up_args(task, **options)) == expert
    assert planner_argv(up_args(task, **options), None)[:3] == ["planner", "--policy", expert]


def test_a_named_policy_or_a_task_file_keeps_what_was_asked(tmp_path: Path) -> None:
    assert planner_policy(up_args("shelf", policy="sage.pt")) == "sage.pt"
    assert planner_policy(up_args("dishwasher", policy="expert", task_file=tmp_path)) == "expert"


def test_every_familys_default_expert_is_a_registered_policy() -> None:
    named = {
        family.expert_of({"preference": preference})
        for _, family in FAMILIES.items()
        if family.expert_of is not None
        for preference in (None, "top-bottom", "left-right")
    }
    assert named and named <= set(POLICIES.names())
