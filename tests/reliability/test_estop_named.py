"""An engaged emergency stop is named everywhere: ``status`` and ``doctor`` show it, ``run``
is refused with ``estop_engaged`` and a non-zero exit, and an episode it cuts ends with that
reason."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest
from reliability_helpers import STARTUP, Inbox, start

from manigraph_shared.messages import Action, EmergencyStop, EpisodeEvent, EpisodePhase
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

#: Long enough (24+ decisions) that a stop sent at the first decision finds it under way.
RUN_TWO_LONG_EPISODES = ("run", "--episodes", "2", "--blocks", "12", "--json")


def last_json(text: str) -> dict[str, object]:
    return json.loads(text.strip().splitlines()[-1])


def test_a_stopped_stack_shows_the_stop_and_refuses_run_until_resumed(
    running_stack: Stack,
) -> None:
    start(running_stack, "sim", "skills", "planner")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", "planner", timeout=STARTUP)
    before = time.time()
    stopped = running_stack.run("stop", "--reason", "fence open", "--by", "ana", timeout=60)
    assert stopped.returncode == 0, stopped.stderr

    status = running_stack.run("status", "--json", timeout=60)
    report = last_json(status.stdout)
    assert report["estop_engaged"] is True
    estop = report["estop"]
    assert isinstance(estop, dict)
    assert (estop["engaged"], estop["reason"], estop["by"]) == (True, "fence open", "ana")
    assert before - 1 <= estop["since"] <= time.time()
    assert "ESTOP ENGAGED: fence open; by ana" in running_stack.run("status", timeout=60).stdout

    doctor = running_stack.run("doctor", "--json", timeout=60)
    assert doctor.returncode == 0, doctor.stdout  # the services are fine: the robot is held
    health = last_json(doctor.stdout)
    assert health["estop_engaged"] is True
    assert health["estop"]["reason"] == "fence open"  # type: ignore[index]
    assert "ESTOP ENGAGED: fence open (by ana" in running_stack.run("doctor", timeout=60).stdout

    run = running_stack.run("run", "--episodes", "3", timeout=120)
    assert run.returncode != 0, run.stderr
    summary = last_json(run.stdout)
    assert summary["episodes"] == 1  # the run ends at the first refusal
    (result,) = summary["results"]  # type: ignore[misc]
    assert result["reason"] == "estop_engaged: fence open (by ana)"
    assert summary["aborted"] == result["reason"]
    assert (
        run.stderr.strip().splitlines()[-1] == "manigraph run: estop_engaged: fence open (by ana)"
    )

    assert running_stack.run("resume", timeout=60).returncode == 0
    assert (
        last_json(running_stack.run("status", "--json", timeout=60).stdout)["estop_engaged"]
        is False
    )
    again = running_stack.run("run", "--episodes", "1", timeout=120)
    assert again.returncode == 0, again.stderr
    assert last_json(again.stdout)["success_rate"] == 1.0


def test_a_stop_mid_episode_ends_it_with_estop_engaged(running_stack: Stack) -> None:
    start(running_stack, "sim", "skills", "planner")
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", "planner", timeout=STARTUP)
        actions, events = Inbox(bus, Action), Inbox(bus, EpisodeEvent)
        time.sleep(0.3)  # the subscriptions reach the router
        run = subprocess.Popen(
            [sys.executable, "-m", "manigraph_shared.cli", *RUN_TWO_LONG_EPISODES],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=running_stack.env_as("client"),
        )
        try:
            first = actions.wait(lambda a: True, timeout=60)
            bus.publish(EmergencyStop(engaged=True, reason="mid", by="test", stamp=time.time()))
            end = events.wait(
                lambda e: e.phase is EpisodePhase.END and e.episode_id == first.episode_id
            )
            stdout, stderr = run.communicate(timeout=60)
        finally:
            if run.poll() is None:
                run.kill()
                run.wait()
    assert end.reason == "estop_engaged: mid (by test)"
    assert end.success is False and end.goals_filled < end.goals_total
    assert run.returncode != 0, stderr
    summary = last_json(stdout)
    assert summary["episodes"] == 1
    assert summary["results"][0]["reason"] == end.reason  # type: ignore[index]
