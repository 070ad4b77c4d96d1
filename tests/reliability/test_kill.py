"""A killed service costs one episode at most: kill -9 mid-episode, restart, the run goes on.

Router, sim, planner and skills run as real processes; ``manigraph run`` runs four episodes;
the service is killed with SIGKILL during the second episode, at its third decision, and
started again. The run must still print its JSON summary, with that episode failed for a
named reason (soon after the kill) and every other episode successful.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
import time

import pytest
from reliability_helpers import STARTUP, start

from manigraph_shared.messages import Action
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

EPISODES = 4
RUN = (sys.executable, "-m", "manigraph_shared.cli", "run")


def run_and_kill(stack: Stack, victim: str) -> tuple[dict, float, str]:
    """Start a 4-episode run, kill ``victim`` at the second episode's third decision, start it
    again; returns the summary, when the kill happened (monotonic), and the run's stderr."""
    start(stack, "sim", "planner", "skills")
    killed_at: list[float] = []
    second = threading.Event()
    with stack.client() as bus:
        stack.wait_alive(bus, "sim", "planner", "skills", timeout=STARTUP)

        def on_action(action: Action) -> None:
            # Mid-episode: two skills done, the third under way. Killed from this callback,
            # within a millisecond of the decision, not after a thread switch.
            if action.episode_id.endswith("-0001") and action.decision_id.endswith(":2"):
                if not second.is_set():
                    stack.processes[victim].send_signal(signal.SIGKILL)
                    killed_at.append(time.monotonic())
                second.set()

        bus.subscribe(Action, on_action)
        time.sleep(0.3)
        run = subprocess.Popen(
            [*RUN, "--blocks", "9", "--episodes", str(EPISODES), "--timeout", "60"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=stack.env,
        )
        try:
            assert second.wait(90), "the second episode never started"
            stack.processes[victim].wait()
            stack.processes.pop(victim)
            stack.start(victim, victim)  # what a supervisor does
            stdout, stderr = run.communicate(timeout=180)
        finally:
            if run.poll() is None:
                run.kill()
                run.communicate()
    assert run.returncode == 0, stderr[-3000:]
    return json.loads(stdout.strip().splitlines()[-1]), killed_at[0], stderr


@pytest.mark.parametrize("victim", ["skills", "sim"])
def test_kill_9_mid_episode_fails_that_episode_only(running_stack: Stack, victim: str) -> None:
    summary, killed_at, stderr = run_and_kill(running_stack, victim)
    results = summary["results"]
    print(f"{victim} killed; run ended {time.monotonic() - killed_at:.1f} s later:", results)
    assert summary["episodes"] == EPISODES, stderr[-3000:]
    failed = [r for r in results if not r["success"]]
    assert len(failed) == 1, results
    assert failed[0]["episode_id"].endswith("-0001")
    assert failed[0]["reason"].startswith(f"service_lost: {victim}"), failed[0]
    assert all(r["success"] for r in results if r is not failed[0]), results
    # Failed within a few seconds of the kill: the kill came at its third decision, so the
    # whole episode (reset, three decisions, failure) lasts well under 5 s.
    assert failed[0]["seconds"] < 5.0, failed[0]
