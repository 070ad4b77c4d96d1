"""Recorded logs drive a fresh planner: the regression guard for policies."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from manigraph_shared.mcap_log import McapLogWriter, read_log
from manigraph_shared.messages import Action, Scene
from manigraph_testkit.testing import Stack, run_up

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    log = tmp_path_factory.mktemp("recorded") / "run.mcap"
    run_up("--blocks", "5", "--episodes", "2", "--seed", "3", "--record", str(log), timeout=120)
    return log


def replay_against_fresh_planner(stack: Stack, log: Path) -> subprocess.CompletedProcess[str]:
    stack.start("router")
    stack.start("planner", "planner")
    return stack.run("replay", str(log), "--expect-actions", "--speed", "4")


def test_replay_drives_a_fresh_planner_to_the_same_actions(
    running_stack: Stack, recorded_run: Path
) -> None:
    result = replay_against_fresh_planner(running_stack, recorded_run)
    assert result.returncode == 0, result.stderr[-2000:] + running_stack.log("planner")
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["identical"] is True
    assert summary["decisions_expected"] == summary["decisions_received"] == 10


def test_a_changed_decision_in_the_log_is_caught(
    running_stack: Stack, recorded_run: Path, tmp_path: Path
) -> None:
    tampered = tmp_path / "tampered.mcap"
    writer = McapLogWriter(tampered)
    changed = False
    for item in read_log(recorded_run):
        data = item.data
        if item.topic == Action.key and not changed:
            action = Action.decode(data)
            data = action.replace(goal_id="goal_4").encode()
            changed = action.goal_id != "goal_4"
        writer.write(item.topic, data, item.log_time_ns)
    writer.close()
    assert changed
    result = replay_against_fresh_planner(running_stack, tampered)
    assert result.returncode == 1
    assert (
        "MISMATCH" in result.stderr
        and json.loads(result.stdout.splitlines()[-1])["mismatches"] == 1
    )


def test_a_replay_that_goes_on_without_a_decision_says_so(
    running_stack: Stack, recorded_run: Path
) -> None:
    running_stack.start("router")  # and no planner: no decision will come
    base = ("replay", str(recorded_run), "--expect-actions", "--wait-for")
    result = running_stack.run(*base, "--decision-timeout", "0.05", "--keep-going")
    assert result.returncode == 1
    assert result.stderr.count("got nothing within 0.05 s") == 10
    assert json.loads(result.stdout.splitlines()[-1])["decisions_received"] == 0
    first = running_stack.run(*base, "--decision-timeout", "0.05")  # stops at the first
    assert first.returncode == 1
    assert first.stderr.count("MISMATCH") == 1
    assert "stopped at the first divergence, after 1 of the log's 10 decisions" in first.stderr


def test_topic_filter_publishes_only_matching_keys(
    running_stack: Stack, recorded_run: Path
) -> None:
    running_stack.start("router")
    seen: list[str] = []
    with running_stack.client() as bus:
        bus.subscribe_raw("manigraph/**", lambda sample: seen.append(str(sample.key_expr)))
        running_stack.wait_alive(bus, "router")
        result = running_stack.run(
            "replay", str(recorded_run), "--topics", Scene.key, "--speed", "20"
        )
        assert result.returncode == 0, result.stderr
        import time

        time.sleep(0.5)
    assert seen and set(seen) == {Scene.key}
    assert len(seen) == len(list(read_log(recorded_run, [Scene.key])))
