"""The emergency stop: refused while engaged, accepted after resume, logged to MCAP; the
skill under way is reported stopped at once even while the driver is inside a long call."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from reliability_helpers import (
    STARTUP,
    Inbox,
    action,
    rejections,
    reset,
    scene_of,
    start,
    top_block_and_free_goal,
)

from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import (
    EmergencyStop,
    Scene,
    ServiceStatus,
    SkillState,
    SkillStatus,
)
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration


def test_actions_are_refused_while_stopped_and_accepted_after_resume(
    running_stack: Stack, tmp_path: Path
) -> None:
    log = tmp_path / "estop.mcap"
    start(running_stack, "sim", "skills")
    running_stack.start("recorder", "record", "--output", str(log))
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", "recorder", timeout=STARTUP)
        scenes, skill = Inbox(bus, Scene), Inbox(bus, SkillStatus)
        statuses = Inbox(bus, ServiceStatus)
        time.sleep(0.3)
        reset(bus, "estop")
        real = scene_of(scenes, "estop")
        block, goal = top_block_and_free_goal(real)

        stopped = running_stack.run("stop", "--reason", "test", timeout=30)
        assert stopped.returncode == 0, stopped.stderr  # skills acknowledged it
        bus.publish(action(real, block, goal, "estop:0"))
        refused = skill.wait(lambda s: s.decision_id == "estop:0" and s.state.terminal)
        assert refused.state is SkillState.FAILED and refused.reason == "stopped"
        assert rejections(statuses, "skills", "Action:stopped") == 1

        # The stop cut the episode under way: a new one starts after resume.
        resumed = running_stack.run("resume", timeout=30)
        assert resumed.returncode == 0, resumed.stderr
        reset(bus, "estop-2")
        real = scene_of(scenes, "estop-2")
        block, goal = top_block_and_free_goal(real)
        bus.publish(action(real, block, goal, "estop-2:1"))
        done = skill.wait(lambda s: s.decision_id == "estop-2:1" and s.state.terminal)
        assert done.state is SkillState.SUCCEEDED, done
        time.sleep(0.5)  # the recorder flushes every 100 ms
    running_stack.stop("recorder")
    logged = [EmergencyStop.decode(m.data) for m in read_log(log, [EmergencyStop.key])]
    assert [(m.engaged, m.reason) for m in logged] == [(True, "test"), (False, "manigraph resume")]


# A real skills service process whose driver's first pick is one long call that does not look
# at the stop (what IK and collision re-plans are on a loaded machine: seconds); it notices
# the stop only when the call returns, as a real driver would.
BLOCKING_SKILLS = """
import sys, time
from manigraph_shared.bus_config import BusConfig
from manigraph_shared.errors import SkillError
from manigraph_shared.service import run_service
from manigraph_skills.drivers.base import RobotDriver
from manigraph_skills.service import SkillsService
from manigraph_shared.workspace import Workspace

class LongPlanning(RobotDriver):
    name = "long-planning"

    def __init__(self):
        self.stopped = False
        self.picks = 0

    def pick(self, motion):
        self.picks += 1
        if self.picks == 1:
            time.sleep(6.0)
        if self.stopped:
            raise SkillError("stopped", "noticed after the long call")

    def place(self, motion):
        pass

    def stop(self):
        self.stopped = True

    def resume(self):
        self.stopped = False

run_service(
    lambda bus: SkillsService(bus, lambda _bus: LongPlanning(), Workspace()),
    BusConfig(connect=(sys.argv[1],)),
)
"""


def test_a_stop_during_a_long_driver_call_is_reported_at_once_and_only_once(
    running_stack: Stack,
) -> None:
    start(running_stack, "sim")
    running_stack.processes["skills"] = subprocess.Popen(  # type: ignore[assignment]
        [sys.executable, "-c", BLOCKING_SKILLS, running_stack.endpoint],
        env=running_stack.env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "sim", "skills", timeout=STARTUP)
        scenes, skill = Inbox(bus, Scene), Inbox(bus, SkillStatus)
        time.sleep(0.3)
        reset(bus, "long")
        real = scene_of(scenes, "long")
        block, goal = top_block_and_free_goal(real)
        bus.publish(action(real, block, goal, "long:0"))
        skill.wait(lambda s: s.decision_id == "long:0" and s.state is SkillState.RUNNING)
        time.sleep(0.5)  # the driver is inside its long call
        sent = time.monotonic()
        bus.publish(EmergencyStop(engaged=True, reason="test", stamp=time.time()))
        stopped = skill.wait(lambda s: s.decision_id == "long:0" and s.state.terminal)
        latency = time.monotonic() - sent
        assert stopped.state is SkillState.FAILED and stopped.reason == "stopped"
        # before the fix the stop was reported when the 6 s call returned; the target is
        # 100 ms, the bound leaves room for a loaded machine
        assert latency < 1.5, f"stopped reported {latency:.2f} s after the stop"

        time.sleep(7.0)  # the long call returns and the worker ends the decision
        finals = [s for s in skill.seen if s.decision_id == "long:0" and s.state.terminal]
        assert len(finals) == 1, finals  # the worker's own report is dropped

        resumed = running_stack.run("resume", timeout=60)
        assert resumed.returncode == 0, resumed.stderr
        reset(bus, "long-2")  # the stop cut the episode under way
        real = scene_of(scenes, "long-2")
        block, goal = top_block_and_free_goal(real)
        bus.publish(action(real, block, goal, "long-2:1"))
        done = skill.wait(lambda s: s.decision_id == "long-2:1" and s.state.terminal)
        assert done.state is SkillState.SUCCEEDED, done
