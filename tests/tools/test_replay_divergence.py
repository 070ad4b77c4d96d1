"""`manigraph replay --expect-actions` against a planner that decides otherwise than the log:
it stops at the first divergence and names it, with both choices."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[2]
#: Recorded with the Sage checkpoint; the GCN checkpoint takes block_4 to goal_1 instead of
#: goal_0 at its second decision (tests/regression/test_golden_logs.py pins the Sage ones).
LOG = REPO / "tests" / "golden" / "sage-pyramid6.mcap"
OTHER_CHECKPOINT = REPO / "checkpoints" / "gcn.pt"
FIRST_DIVERGENCE = (
    "decision 1 (episode pyramid-6-1795550353-0000:1): recorded block_4 -> goal_0, "
    "got block_4 -> goal_1"
)


def replay(stack: Stack, *extra: str) -> tuple[int, str, dict[str, object]]:
    stack.start("router")
    stack.start("planner", "planner", "--policy", str(OTHER_CHECKPOINT))
    result = stack.run("replay", str(LOG), "--expect-actions", "--speed", "4", *extra)
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    return result.returncode, result.stderr, summary


def test_a_divergent_planner_stops_the_replay_at_its_first_different_decision(
    running_stack: Stack,
) -> None:
    if not OTHER_CHECKPOINT.is_file():
        pytest.skip(f"no shipped checkpoint {OTHER_CHECKPOINT}")
    code, stderr, summary = replay(running_stack)
    assert code == 1, stderr[-2000:]
    mismatches = [line for line in stderr.splitlines() if line.startswith("MISMATCH")]
    assert mismatches == [f"MISMATCH {FIRST_DIVERGENCE}"], stderr[-2000:]
    assert "stopped at the first divergence, after 2 of the log's 6 decisions" in stderr
    assert summary["first_mismatch"] == FIRST_DIVERGENCE
    assert summary["stopped_early"] is True
    assert (summary["decisions_expected"], summary["decisions_checked"]) == (6, 2)
    assert summary["identical"] is False


def test_keep_going_checks_every_recorded_decision(running_stack: Stack) -> None:
    if not OTHER_CHECKPOINT.is_file():
        pytest.skip(f"no shipped checkpoint {OTHER_CHECKPOINT}")
    code, stderr, summary = replay(running_stack, "--keep-going", "--decision-timeout", "1")
    assert code == 1, stderr[-2000:]
    assert summary["first_mismatch"] == FIRST_DIVERGENCE
    assert summary["stopped_early"] is False
    assert summary["decisions_checked"] == 6
    assert summary["mismatches"] >= 1


def test_a_decision_timeout_that_is_not_positive_is_refused_in_one_line(
    running_stack: Stack,
) -> None:
    result = running_stack.run(
        "replay", str(LOG), "--expect-actions", "--decision-timeout", "0", timeout=60
    )
    assert result.returncode != 0
    assert result.stderr.strip().count("\n") == 0, result.stderr
    assert "decision-timeout" in result.stderr and "> 0" in result.stderr
