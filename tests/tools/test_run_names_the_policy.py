"""``manigraph run``'s summary names the policy the stack's planner serves, and for a
checkpoint its file and SHA-256, with floats rounded (a real stack on loopback)."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from pathlib import Path

import pytest

from manigraph_shared.results import FLOAT_DIGITS
from manigraph_testkit.testing import Stack
from manigraph_tools.served_policy import served_policy

pytestmark = pytest.mark.integration

CHECKPOINT = Path(__file__).resolve().parents[2] / "checkpoints" / "sage.pt"


def _start(stack: Stack, policy: str) -> None:
    stack.start("router")
    for name, *args in (("sim",), ("skills",), ("planner", "--policy", policy)):
        stack.start(name, name, *args)
    with stack.client() as bus:
        stack.wait_alive(bus, "sim", "skills", "planner")


def test_run_names_the_planners_checkpoint_by_path_and_digest(
    running_stack: Stack, tmp_path: Path
) -> None:
    policy = shutil.copy(CHECKPOINT, tmp_path / "sage-seed0.pt")
    _start(running_stack, str(policy))

    result = running_stack.run("run", "--blocks", "3", "--episodes", "1", "--json", timeout=300)

    assert result.returncode == 0, result.stderr
    line = result.stdout.strip().splitlines()[-1]
    summary = json.loads(line)
    assert summary["policy"] == "gnn-sage"
    assert summary["checkpoint"] == {
        "path": str(policy),
        "sha256": hashlib.sha256(CHECKPOINT.read_bytes()).hexdigest(),
    }
    for number in re.findall(r"\d+\.\d+", line):
        assert len(number.split(".")[1]) <= FLOAT_DIGITS, number


def test_a_registered_policy_is_named_without_a_checkpoint(running_stack: Stack) -> None:
    _start(running_stack, "expert")
    with running_stack.client() as bus:
        assert served_policy(bus) == {"policy": "expert"}


def test_no_planner_names_no_policy(running_stack: Stack) -> None:
    running_stack.start("router")
    with running_stack.client() as bus:
        assert served_policy(bus, wait=0.5) == {}
