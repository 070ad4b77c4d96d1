"""``doctor`` tells a stalled service (alive, but its thread stuck) from a healthy one."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from manigraph_shared.messages import EpisodeEvent, EpisodePhase
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

# A real service process whose one handler never returns (within the test) on an episode event.
STUCK_SERVICE = """
import sys, time
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.messages import EpisodeEvent
from manigraph_shared.service import Service, run_service

class Stuck(Service):
    name = "stuck"

    def setup(self):
        self.on(EpisodeEvent, lambda event: time.sleep(120))

run_service(Stuck, BusConfig(connect=(sys.argv[1],)))
"""


def test_a_service_whose_thread_is_stuck_is_reported_stalled(running_stack: Stack) -> None:
    running_stack.start("router")
    stuck = subprocess.Popen(
        [sys.executable, "-c", STUCK_SERVICE, running_stack.endpoint],
        env=running_stack.env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    running_stack.processes["stuck"] = stuck  # type: ignore[assignment]
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "stuck")
        healthy = running_stack.run("doctor", "--expect", "router", "stuck", "--json")
        assert healthy.returncode == 0, healthy.stdout + healthy.stderr
        assert json.loads(healthy.stdout)["stalled"] == []

        bus.publish(
            EpisodeEvent(
                episode_id="e",
                phase=EpisodePhase.START,
                task="stack",
                seed=0,
                goals_total=1,
                goals_filled=0,
                stamp=time.time(),
            )
        )
        time.sleep(1.5)  # the heartbeat that was due is now missed
        stalled = running_stack.run("doctor", "--expect", "router", "stuck", "--json")
        assert stalled.returncode == 1
        report = json.loads(stalled.stdout)
        assert report["stalled"] == ["stuck"] and "stuck" in report["alive"]
        table = running_stack.run("doctor", "--expect", "router", "stuck")
        assert "| stuck | STALLED (no heartbeat for 3 s) |" in table.stdout
        # liveliness alone (the old check) would call it healthy
        assert (
            running_stack.run("doctor", "--expect", "stuck", "--stall-seconds", "0").returncode == 0
        )
